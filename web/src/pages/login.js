// Login with a bearer token (decision 015 tokens dgw_<id>_<secret>); kept in sessionStorage.
import { h, showError } from '../ui.js';
import { token, session, loadSession } from '../api.js';

export function render(root) {
  token.set('');
  session.loaded = false;
  const input = h('input', { type: 'password', 'data-testid': 'login-token', placeholder: 'dgw_…', size: 50, autocomplete: 'off' });
  const msg = h('p');
  const form = h(
    'form',
    {
      class: 'card login',
      onsubmit: async (ev) => {
        ev.preventDefault();
        token.set(input.value.trim());
        try {
          await loadSession();
          location.hash = '#/fleet';
        } catch (e) {
          token.set('');
          session.loaded = false;
          showError(msg, e.status === 401 ? { message: 'token not accepted' } : e);
        }
      },
    },
    h('h2', {}, 'Log in'),
    h('p', {}, 'This gateway requires a token (create one with ', h('code', {}, 'drivegw token create'), ').'),
    input,
    ' ',
    h('button', { type: 'submit', 'data-testid': 'login-submit' }, 'Log in'),
    msg,
  );
  root.append(form);
  input.focus();
}
