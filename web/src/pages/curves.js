// Curves: every curve of every stored set; a plot of position, velocity and acceleration
// (GET …:plot, decision 012) and RunCurve on a drive.
import uPlot from 'uplot';
import { h, showError } from '../ui.js';
import { get, post, can, follow, short } from '../api.js';

export async function render(root) {
  const [cs, { drives = [] }] = await Promise.all([get('/v1/curveSets'), get('/v1/drives')]);
  const sets = cs.curveSets || cs.curve_sets || [];
  const plotBox = h('div', { 'data-testid': 'curve-plot', class: 'chart' });
  const select = h('select', { 'data-testid': 'curve-drive' }, drives.map((d) => h('option', { value: short(d.name) }, short(d.name))));
  const state = h('div', { 'data-testid': 'curve-run-state' });
  const msg = h('div', { 'data-testid': 'curve-error' });
  // RunCurve needs the operator role (decision 015's table: motion and power).
  const operator = can('operator');
  let chosen = null;
  let plot = null;

  const open = async (set, curve) => {
    showError(msg, null);
    chosen = { set, curve };
    try {
      const p = await get(`/v1/curveSets/${set}/curves/${curve}:plot`);
      if (plot) plot.destroy();
      plotBox.replaceChildren(h('h3', {}, `${set} / ${curve}`));
      plot = new uPlot(
        {
          width: Math.max(400, Math.min(900, window.innerWidth - 60)),
          height: 260,
          scales: { x: { time: false } },
          series: [
            { label: 's' },
            { label: 'position mm', stroke: '#1565c0', scale: 'mm' },
            { label: 'velocity mm/s', stroke: '#ef6c00', scale: 'v' },
            { label: 'acceleration mm/s²', stroke: '#2e7d32', scale: 'a' },
          ],
          axes: [{}, { scale: 'mm' }, { scale: 'v', side: 1, grid: { show: false } }],
        },
        [p.t_s || [], p.position_mm || [], p.velocity_mm_s || [], p.acceleration_mm_s2 || []],
        plotBox,
      );
    } catch (e) {
      showError(msg, e);
    }
  };

  const runCurve = async () => {
    if (!chosen) return showError(msg, { message: 'choose a curve first' });
    showError(msg, null);
    try {
      const handle = await post(`/v1/drives/${select.value}:runCurve`, { name: chosen.set, curve: chosen.curve });
      await follow(handle, (c) => {
        const pr = typeof c.progress === 'number' ? ` ${Math.round(c.progress * 100)} %` : '';
        state.textContent = `${c.kind}: ${c.state}${pr}${c.message ? ` — ${c.message}` : ''}`;
      });
    } catch (e) {
      showError(msg, e);
    }
  };

  const rows = sets.flatMap((s) =>
    (s.curves || []).map((c) =>
      h(
        'tr',
        { 'data-testid': `curve-row-${short(s.name)}-${c.name}`, class: 'click', onclick: () => open(short(s.name), c.name) },
        h('td', {}, short(s.name)),
        h('td', {}, c.name),
        h('td', {}, c.position_time ? 'position/time' : 'LinMot'),
        h('td', {}, c.description || ''),
      ),
    ),
  );
  root.append(
    h('h2', {}, 'Curves'),
    h('table', {}, h('thead', {}, h('tr', {}, ...['Set', 'Curve', 'Kind', 'Description'].map((t) => h('th', {}, t)))), h('tbody', {}, rows)),
    rows.length ? '' : h('p', {}, 'No curve sets stored.'),
    plotBox,
    h(
      'div',
      { class: 'row' },
      'Drive ',
      select,
      ' ',
      h('button', { 'data-testid': 'btn-run-curve', onclick: runCurve, disabled: !operator, hidden: !operator }, 'Run curve'),
    ),
    state,
    msg,
  );
  return () => plot && plot.destroy();
}
