// The REST API (README "Try it", /openapi.json) with the bearer token of the login page.
// The token lives in sessionStorage: gone when the tab closes (issue 8, decision 506).
const KEY = 'drivegw.token';

export const token = {
  get: () => sessionStorage.getItem(KEY) || '',
  set: (t) => (t ? sessionStorage.setItem(KEY, t) : sessionStorage.removeItem(KEY)),
};

// Errors carry the HTTP status and the API's own message (the validation text to show).
export class ApiError extends Error {
  constructor(status, body) {
    super(body?.message || `HTTP ${status}`);
    this.status = status;
    this.code = body?.code;
  }
}

export async function api(method, path, body) {
  const headers = {};
  const t = token.get();
  if (t) headers.Authorization = `Bearer ${t}`;
  if (body !== undefined) headers['Content-Type'] = 'application/json';
  const r = await fetch(path, { method, headers, body: body === undefined ? undefined : JSON.stringify(body) });
  const text = await r.text();
  let data = null;
  try {
    data = text ? JSON.parse(text) : null;
  } catch {
    data = { message: text };
  }
  if (!r.ok) throw new ApiError(r.status, data);
  return data;
}

export const get = (path) => api('GET', path);
export const post = (path, body = {}) => api('POST', path, body);

// "drives/x1" -> "x1" (resource names of the API, AIP-122).
export const short = (name) => (name || '').split('/').pop();

// whoami (contract of issue 8): who the token is and what role it has.
export const session = { principal: '', role: '', auth_enabled: false, loaded: false };

export async function loadSession() {
  try {
    Object.assign(session, await get('/v1/whoami'), { loaded: true });
  } catch (e) {
    if (e.status !== 404) throw e;
    // A gateway without /v1/whoami (older than issue 8): the API still decides every call.
    // Open mode runs every call as anonymous admin (decision 015); with a token the role is
    // unknown here, so buttons stay usable and the API's 403 says what is refused.
    await get('/v1/drives');
    const role = token.get() ? 'unknown' : 'admin';
    Object.assign(session, { principal: token.get() ? 'token' : 'anonymous', role, auth_enabled: !!token.get(), loaded: true });
  }
  return session;
}

// Roles of decision 015: viewer < operator < engineer < admin.
const RANK = { viewer: 0, operator: 1, engineer: 2, admin: 3 };
export const can = (need) => session.role === 'unknown' || (RANK[session.role] ?? -1) >= RANK[need];

// Polls a command handle until it leaves BUSY/ACTIVE; onUpdate sees every state.
export async function follow(handle, onUpdate) {
  let h = handle;
  onUpdate(h);
  while (h && (h.state === 'BUSY' || h.state === 'ACTIVE')) {
    await new Promise((r) => setTimeout(r, 250));
    h = await get(`/v1/${h.name}`);
    onUpdate(h);
  }
  return h;
}
