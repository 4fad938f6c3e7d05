// Live drive status: the WebSocket of issue 8 (GET /v1/drives:ws), reconnecting with backoff.
// Frames: {"type":"status","status":DriveStatus} or {"type":"error",...} then close. The token
// goes in access_token because browsers cannot set headers on a WebSocket.
// A gateway without the WebSocket route (three failed opens in a row) is read through the
// newline-delimited JSON of GET /v1/drives:watch instead: the same status stream (README).
import { token } from './api.js';

export function watchDrives(names, onStatus, onLink = () => {}) {
  let ws = null;
  let closed = false;
  let fails = 0;
  let delay = 500;
  const abort = new AbortController();

  const query = () => {
    const q = new URLSearchParams({ max_rate_hz: '10' });
    if (names) q.set('names', names.join(','));
    return q;
  };

  function connect() {
    if (closed) return;
    const q = query();
    if (token.get()) q.set('access_token', token.get());
    const proto = location.protocol === 'https:' ? 'wss:' : 'ws:';
    let opened = false;
    ws = new WebSocket(`${proto}//${location.host}/v1/drives:ws?${q}`);
    ws.onopen = () => {
      opened = true;
      fails = 0;
      delay = 500;
      onLink('live');
    };
    ws.onmessage = (ev) => {
      const m = JSON.parse(ev.data);
      if (m.type === 'status') onStatus(m.status);
      else if (m.type === 'error') onLink(`error: ${m.message}`);
    };
    ws.onclose = () => {
      if (closed) return;
      if (!opened && ++fails >= 3) return stream();
      onLink('reconnecting');
      setTimeout(connect, delay);
      delay = Math.min(delay * 2, 5000);
    };
  }

  async function stream() {
    while (!closed) {
      try {
        const headers = token.get() ? { Authorization: `Bearer ${token.get()}` } : {};
        const r = await fetch(`/v1/drives:watch?${query()}`, { headers, signal: abort.signal });
        if (!r.ok) throw new Error(`HTTP ${r.status}`);
        onLink('live');
        const reader = r.body.pipeThrough(new TextDecoderStream()).getReader();
        let buf = '';
        for (;;) {
          const { value, done } = await reader.read();
          if (done) break;
          buf += value;
          let i;
          while ((i = buf.indexOf('\n')) >= 0) {
            const line = buf.slice(0, i).trim();
            buf = buf.slice(i + 1);
            if (!line) continue;
            const m = JSON.parse(line);
            onStatus(m.result ?? m.status ?? m);
          }
        }
      } catch (e) {
        if (closed) return;
      }
      onLink('reconnecting');
      await new Promise((r) => setTimeout(r, delay));
    }
  }

  connect();
  return () => {
    closed = true;
    abort.abort();
    if (ws) ws.close();
  };
}
