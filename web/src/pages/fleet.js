// Fleet: one card per drive, live from the status stream (ws.js).
import { h, fmt, sparkline } from '../ui.js';
import { get, short } from '../api.js';
import { watchDrives } from '../ws.js';

const TREND = 60; // samples of the small position trend (about 6 s at 10 Hz)

export async function render(root) {
  const link = h('span', { class: 'link' }, 'connecting');
  const grid = h('div', { class: 'grid' });
  root.append(h('h2', {}, 'Fleet ', link), grid);
  const { drives = [] } = await get('/v1/drives');
  const cards = new Map();
  for (const d of drives) {
    const name = short(d.name);
    const c = {
      trend: [],
      el: {
        state: h('span', { 'data-testid': 'state', class: 'state' }),
        native: h('span', { class: 'native' }),
        position: h('span', { 'data-testid': 'position' }),
        trend: h('span'),
        flags: h('div', { class: 'flags' }),
        warnings: h('div', { class: 'warnings' }),
        fault: h('div', { 'data-testid': 'fault', class: 'fault' }),
        link: h('div', { 'data-testid': 'link', class: 'flags' }),
      },
    };
    const e = c.el;
    grid.append(
      h(
        'a',
        { class: 'card drive', href: `#/drives/${name}`, 'data-testid': `drive-card-${name}` },
        h('h3', {}, name, h('small', {}, ` ${d.family}`)),
        h('div', {}, e.state, ' ', e.native),
        h('div', {}, e.position, ' mm ', e.trend),
        e.flags,
        e.warnings,
        e.fault,
        e.link,
      ),
    );
    cards.set(name, c);
    if (d.status) update(c, d.status);
  }
  return watchDrives(null, (s) => {
    const c = cards.get(short(s.name));
    if (c) update(c, s);
  }, (l) => (link.textContent = l));
}

function update(c, s) {
  const e = c.el;
  e.state.textContent = s.state;
  e.state.dataset.state = s.state;
  e.native.textContent = s.native_state?.text || '';
  e.position.textContent = fmt(s.position_mm);
  c.trend.push(s.position_mm ?? 0);
  if (c.trend.length > TREND) c.trend.shift();
  e.trend.replaceChildren(sparkline(c.trend));
  e.flags.textContent = `${s.homed ? 'homed' : 'not homed'} · ${s.in_target ? 'in target' : 'not in target'}`;
  e.warnings.textContent = (s.warnings || []).join(', ');
  e.fault.textContent = s.fault ? `${s.fault.code} ${s.fault.text}` : '';
  // Link health (issue 8): refreshed with each snapshot the stream sends (only changed ones).
  if (s.link) e.link.textContent = linkText(s.link, s.health);
}

// "rt 1.2 ms · missed 0 · UP"; uint64 arrive as JSON strings, the round trip is absent when unknown.
// Device health (decision 1431) follows: "· DOWN since 2026-12-07T05:12:03Z (3 consecutive
// time-outs)"; UP shows the state only.
function linkText(l, h) {
  const rt = l.last_round_trip_ms;
  let text = `rt ${rt == null ? '–' : `${Number(rt).toFixed(1)} ms`} · missed ${l.missed ?? 0}`;
  if (h?.state) {
    text += ` · ${h.state}`;
    if (h.state !== 'UP' && h.since) text += ` since ${h.since}`;
    if (h.state !== 'UP' && h.reason) text += ` (${h.reason})`;
  }
  return text;
}
