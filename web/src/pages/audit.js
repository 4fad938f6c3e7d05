// Audit log: filters (time, drive, principal, action), paging with page_token, the chain's
// verification status (POST /v1/auditLog:verify) and one entry in full (decision 017).
import { h, showError } from '../ui.js';
import { get, post } from '../api.js';

const PAGE = 50;

export async function render(root) {
  const f = {
    start: h('input', { type: 'datetime-local', 'data-testid': 'audit-filter-start' }),
    end: h('input', { type: 'datetime-local', 'data-testid': 'audit-filter-end' }),
    drive: h('input', { 'data-testid': 'audit-filter-drive', placeholder: 'drive', size: 10 }),
    principal: h('input', { 'data-testid': 'audit-filter-principal', placeholder: 'principal', size: 12 }),
    action: h('input', { 'data-testid': 'audit-filter-action', placeholder: 'action', size: 16 }),
  };
  const verify = h('span', { 'data-testid': 'audit-verify-status' }, 'verifying…');
  const body = h('tbody');
  const detail = h('pre', { 'data-testid': 'audit-detail', class: 'card detail' });
  const msg = h('div');
  const pager = h('span');
  const pages = ['']; // page tokens: pages[i] starts page i
  let page = 0;

  const iso = (input) => (input.value ? new Date(input.value).toISOString() : '');
  const load = async () => {
    showError(msg, null);
    const q = new URLSearchParams({ page_size: String(PAGE) });
    const add = (k, v) => v && q.set(k, v);
    add('start_time', iso(f.start));
    add('end_time', iso(f.end));
    add('drive', f.drive.value.trim());
    add('principal', f.principal.value.trim());
    add('action', f.action.value.trim());
    add('page_token', pages[page]);
    try {
      const r = await get(`/v1/auditEvents?${q}`);
      pages[page + 1] = r.next_page_token || '';
      body.replaceChildren(
        ...(r.events || []).map((e) =>
          h(
            'tr',
            { 'data-testid': 'audit-row', 'data-action': e.action, 'data-drive': e.drive || '', class: `click${e.result_code ? ' failed' : ''}`, onclick: () => (detail.textContent = describe(e)) },
            h('td', {}, e.sequence),
            h('td', {}, e.time),
            h('td', {}, e.principal),
            h('td', {}, e.drive || ''),
            h('td', {}, e.action),
            h('td', {}, e.result_code ? `${e.result_code} ${e.result_message}` : 'OK'),
          ),
        ),
      );
      pager.textContent = ` page ${page + 1} `;
      prev.disabled = page === 0;
      next.disabled = !pages[page + 1];
    } catch (e) {
      showError(msg, e);
    }
  };
  const prev = h('button', { onclick: () => (page--, load()) }, '‹ Newer');
  const next = h('button', { onclick: () => (page++, load()) }, 'Older ›');
  const search = () => {
    pages.length = 1;
    page = 0;
    load();
  };

  root.append(
    h('h2', {}, 'Audit log ', h('small', {}, 'chain: '), verify),
    h(
      'form',
      { class: 'row', onsubmit: (ev) => (ev.preventDefault(), search()) },
      'From ', f.start, ' to ', f.end, ' ', f.drive, ' ', f.principal, ' ', f.action, ' ',
      h('button', { type: 'submit', 'data-testid': 'audit-search' }, 'Filter'),
    ),
    msg,
    h('table', {}, h('thead', {}, h('tr', {}, ...['#', 'Time', 'Principal', 'Drive', 'Action', 'Result'].map((t) => h('th', {}, t)))), body),
    h('div', { class: 'row' }, prev, pager, next),
    detail,
  );
  detail.textContent = 'Click an entry to see it in full.';
  await load();
  try {
    const v = await post('/v1/auditLog:verify', {});
    verify.textContent = v.ok
      ? `verified, ${v.verified_entries} entries intact`
      : `BROKEN at sequence ${v.first_broken_link?.sequence ?? '?'}`;
    verify.className = v.ok ? 'ok' : 'error';
  } catch (e) {
    showError(verify, e);
  }
}

// One entry with its JSON fields parsed, for reading.
function describe(e) {
  const parse = (s) => {
    try {
      return s ? JSON.parse(s) : undefined;
    } catch {
      return s;
    }
  };
  return JSON.stringify(
    { ...e, request_json: parse(e.request_json), before_json: parse(e.before_json), after_json: parse(e.after_json) },
    null,
    2,
  );
}
