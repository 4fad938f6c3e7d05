// Hash router (contract of issue 8): #/fleet (default), #/drives/<name>, #/parameter-sets,
// #/curves, #/audit, #/login. Each page module renders into <main> and returns its cleanup.
import './style.css';
import 'uplot/dist/uPlot.min.css';
import { session, loadSession, token } from './api.js';
import * as fleet from './pages/fleet.js';
import * as drive from './pages/drive.js';
import * as psets from './pages/psets.js';
import * as curves from './pages/curves.js';
import * as audit from './pages/audit.js';
import * as login from './pages/login.js';

const routes = [
  [/^#\/fleet$/, fleet],
  [/^#\/drives\/([^/]+)$/, drive],
  [/^#\/parameter-sets$/, psets],
  [/^#\/curves$/, curves],
  [/^#\/audit$/, audit],
  [/^#\/login$/, login],
];

const root = document.getElementById('page');
let cleanup = null;

function showWho() {
  const who = document.querySelector('[data-testid=whoami]');
  who.textContent = session.loaded ? `${session.principal} (${session.role})` : '';
  document.querySelector('.logout').hidden = !(session.loaded && session.auth_enabled);
}

let seq = 0;

async function route() {
  if (cleanup) cleanup();
  cleanup = null;
  // Each route renders into a fresh element: a slow page whose route was left meanwhile writes
  // into a detached element and is cleaned up as soon as it returns.
  const mine = ++seq;
  const view = document.createElement('div');
  root.replaceChildren(view);
  const hash = location.hash || '#/fleet';
  const found = routes.find(([re]) => re.test(hash));
  if (!found) return void (location.hash = '#/fleet');
  const [re, page] = found;
  try {
    if (page !== login && !session.loaded) await loadSession();
    showWho();
    for (const a of document.querySelectorAll('nav a')) a.classList.toggle('active', hash.startsWith(a.getAttribute('href')));
    const done = (await page.render(view, ...hash.match(re).slice(1).map(decodeURIComponent))) || null;
    if (mine === seq) cleanup = done;
    else if (done) done();
  } catch (e) {
    if (e.status === 401) return void (location.hash = '#/login');
    if (mine === seq) view.replaceChildren(Object.assign(document.createElement('p'), { className: 'error', textContent: `${e.status ? `HTTP ${e.status}: ` : ''}${e.message}` }));
  }
}

// Logging out forgets the token and the session; the login page asks again.
document.querySelector('.logout').addEventListener('click', () => {
  token.set('');
  session.loaded = false;
  showWho();
});

window.addEventListener('hashchange', route);
route();
