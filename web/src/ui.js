// A tiny DOM helper: h('div', {class: 'x', 'data-testid': 'y', onclick: f}, child, ...).
export function h(tag, attrs = {}, ...children) {
  const el = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (v === undefined || v === null || v === false) continue;
    if (k.startsWith('on')) el.addEventListener(k.slice(2), v);
    else if (k === 'class') el.className = v;
    else if (k === 'value') el.value = v;
    else el.setAttribute(k, v === true ? '' : v);
  }
  for (const c of children.flat()) if (c !== null && c !== undefined && c !== false) el.append(c);
  return el;
}

export const fmt = (v, digits = 2) => (typeof v === 'number' ? v.toFixed(digits) : '–');

// Shows an API error (its own validation message) in `el`.
export function showError(el, e) {
  el.textContent = e ? `${e.status ? `HTTP ${e.status}: ` : ''}${e.message}` : '';
  el.className = e ? 'error' : '';
}

// A tiny inline trend (SVG polyline) of the last values: cheap enough for every fleet card.
export function sparkline(values, width = 120, height = 28) {
  const svgNs = 'http://www.w3.org/2000/svg';
  const svg = document.createElementNS(svgNs, 'svg');
  svg.setAttribute('width', width);
  svg.setAttribute('height', height);
  svg.setAttribute('class', 'trend');
  if (values.length > 1) {
    const lo = Math.min(...values);
    const hi = Math.max(...values);
    const span = hi - lo || 1;
    const pts = values.map((v, i) => `${((i / (values.length - 1)) * width).toFixed(1)},${(height - 2 - ((v - lo) / span) * (height - 4)).toFixed(1)}`);
    const line = document.createElementNS(svgNs, 'polyline');
    line.setAttribute('points', pts.join(' '));
    svg.append(line);
  }
  return svg;
}
