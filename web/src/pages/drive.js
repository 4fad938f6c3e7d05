// Drive page: live status and a 30 s position/velocity chart (uPlot), the command panel with a
// big always-visible Stop, and the family catalogue's parameters (read, write with the API's
// validation message).
import uPlot from 'uplot';
import { h, fmt, showError } from '../ui.js';
import { get, post, can, follow, short } from '../api.js';
import { watchDrives } from '../ws.js';

const WINDOW_S = 30;

export async function render(root, name) {
  const d = await get(`/v1/drives/${name}`);
  const axis = d.axis || {};
  const operator = can('operator');
  const el = {
    state: h('span', { 'data-testid': 'drive-state', class: 'state' }),
    native: h('span', { class: 'native' }),
    position: h('span', { 'data-testid': 'drive-position' }),
    velocity: h('span'),
    flags: h('span'),
    warnings: h('div', { class: 'warnings' }),
    fault: h('div', { 'data-testid': 'drive-fault', class: 'fault' }),
    command: h('div', { 'data-testid': 'command-state', class: 'command' }),
    error: h('div'),
    chart: h('div', { 'data-testid': 'chart-position', class: 'chart' }),
  };

  // Every command: POST, then follow its handle (home shows its progress this way).
  const run = (verb, body = {}) => async () => {
    showError(el.error, null);
    try {
      const handle = await post(`/v1/drives/${name}:${verb}`, body);
      await follow(handle, (c) => {
        const p = typeof c.progress === 'number' ? ` ${Math.round(c.progress * 100)} %` : '';
        el.command.textContent = `${c.kind}: ${c.state}${p}${c.message ? ` — ${c.message}` : ''}`;
        el.command.dataset.state = c.state;
      });
    } catch (e) {
      showError(el.error, e);
    }
  };
  const button = (testid, label, action, cls = '') =>
    h('button', { 'data-testid': testid, class: cls, onclick: action, disabled: !operator, hidden: !operator }, label);

  const num = (testid, value, unit, min, max) =>
    h('label', {}, h('input', { type: 'number', 'data-testid': testid, value, step: 'any', min, max }), ` ${unit}`);
  const pos = num('move-position', Math.min(Math.max(50, axis.min_mm ?? 0), axis.max_mm ?? 50), 'mm', axis.min_mm, axis.max_mm);
  const vel = num('move-velocity', Math.min(100, axis.max_velocity_mm_s ?? 100), 'mm/s', 0, axis.max_velocity_mm_s);
  const acc = num('move-acceleration', Math.min(1000, axis.max_acceleration_mm_s2 ?? 1000), 'mm/s²', 0, axis.max_acceleration_mm_s2);
  const val = (l) => Number(l.querySelector('input').value);
  const motion = (verb, key) => async () =>
    run(verb, { [key]: val(pos), velocity_mm_s: val(vel), acceleration_mm_s2: val(acc), deceleration_mm_s2: val(acc) })();

  root.append(
    h('div', { class: 'stopbar' }, h('button', { 'data-testid': 'btn-stop', class: 'stop', onclick: run('stop'), disabled: !operator }, 'STOP')),
    h('h2', {}, name, h('small', {}, ` ${d.family} · ${d.endpoint || ''}`)),
    h(
      'div',
      { class: 'card' },
      h('div', {}, 'State: ', el.state, ' ', el.native),
      h('div', {}, 'Position: ', el.position, ' mm · velocity ', el.velocity, ' mm/s · ', el.flags),
      el.warnings,
      el.fault,
    ),
    el.chart,
    h(
      'div',
      { class: 'card' },
      h('h3', {}, 'Commands'),
      h(
        'div',
        { class: 'row' },
        button('btn-enable', 'Enable', run('enable')),
        button('btn-disable', 'Disable', run('disable')),
        button('btn-home', 'Home', run('home')),
        button('btn-ack', 'Acknowledge fault', run('acknowledgeFault')),
      ),
      h('div', { class: 'row' }, 'Target ', pos, ' ', vel, ' ', acc),
      h(
        'div',
        { class: 'row' },
        button('btn-move-absolute', 'Move absolute', motion('moveAbsolute', 'position_mm')),
        button('btn-move-relative', 'Move relative', motion('moveRelative', 'distance_mm')),
      ),
      h(
        'p',
        { class: 'limits' },
        `Axis ${axis.kind || ''}: ${axis.min_mm} … ${axis.max_mm} mm, ≤ ${axis.max_velocity_mm_s} mm/s, ≤ ${axis.max_acceleration_mm_s2} mm/s²`,
      ),
      el.command,
      el.error,
    ),
  );

  const chart = makeChart(el.chart);
  const onStatus = (s) => {
    el.state.textContent = s.state;
    el.state.dataset.state = s.state;
    el.native.textContent = s.native_state?.text || '';
    el.position.textContent = fmt(s.position_mm);
    el.velocity.textContent = fmt(s.velocity_mm_s);
    el.flags.textContent = `${s.homed ? 'homed' : 'not homed'}, ${s.in_target ? 'in target' : 'not in target'}`;
    el.warnings.textContent = (s.warnings || []).join(', ');
    el.fault.textContent = s.fault ? `Fault ${s.fault.code}: ${s.fault.text}` : '';
    chart.push(s);
  };
  if (d.status) onStatus(d.status);
  const stop = watchDrives([name], onStatus);

  root.append(await parameters(d));
  return () => {
    stop();
    chart.destroy();
  };
}

// The last 30 s of position and velocity, redrawn at most every 200 ms.
function makeChart(container) {
  const data = [[], [], []];
  const plot = new uPlot(
    {
      width: Math.max(400, Math.min(900, window.innerWidth - 60)),
      height: 220,
      series: [{}, { label: 'position mm', stroke: '#1565c0', scale: 'mm' }, { label: 'velocity mm/s', stroke: '#ef6c00', scale: 'v' }],
      axes: [{}, { scale: 'mm' }, { scale: 'v', side: 1, grid: { show: false } }],
    },
    data,
    container,
  );
  let last = 0;
  return {
    push(s) {
      const t = s.time ? Date.parse(s.time) / 1000 : Date.now() / 1000;
      data[0].push(t);
      data[1].push(s.position_mm ?? 0);
      data[2].push(s.velocity_mm_s ?? 0);
      while (data[0].length && data[0][0] < t - WINDOW_S) data.forEach((a) => a.shift());
      if (Date.now() - last > 200) {
        last = Date.now();
        plot.setData(data);
      }
    },
    destroy: () => plot.destroy(),
  };
}

// The family catalogue: names, units, ranges; read one value, write with validation.
async function parameters(d) {
  const name = short(d.name);
  const box = h('div', { class: 'card' }, h('h3', {}, 'Parameters'));
  let defs = [];
  try {
    ({ definitions: defs = [] } = await get(`/v1/families/${d.family}/parameterDefinitions`));
  } catch (e) {
    box.append(h('p', { class: 'error' }, e.message));
    return box;
  }
  const engineer = can('engineer');
  const filter = h('input', { placeholder: 'filter', 'data-testid': 'param-filter' });
  const body = h('tbody');
  const draw = () => {
    const f = filter.value.toLowerCase();
    body.replaceChildren(
      ...defs
        .filter((p) => !f || `${p.name} ${p.title}`.toLowerCase().includes(f))
        .slice(0, 100)
        .map((p) => {
          const value = h('span');
          const msg = h('span');
          const input = h('input', { type: 'number', size: 10, min: p.min, max: p.max });
          const read = async () => {
            showError(msg, null);
            try {
              value.textContent = (await get(`/v1/drives/${name}/parameters/${p.id}`)).value;
            } catch (e) {
              showError(msg, e);
            }
          };
          const write = async () => {
            showError(msg, null);
            try {
              await post(`/v1/drives/${name}/parameters/${p.id}:write`, { value: input.value });
              await read();
            } catch (e) {
              showError(msg, e);
            }
          };
          return h(
            'tr',
            { 'data-testid': `param-row-${p.id}` },
            h('td', {}, p.name),
            h('td', {}, p.title),
            h('td', {}, p.unit),
            h('td', {}, `${p.min} … ${p.max}`),
            h('td', {}, value, ' ', h('button', { onclick: read }, 'Read')),
            h('td', {}, p.writable && engineer ? [input, h('button', { onclick: write }, 'Write')] : ''),
            h('td', {}, msg),
          );
        }),
    );
  };
  filter.addEventListener('input', draw);
  draw();
  box.append(
    filter,
    h('span', {}, ` ${defs.length} parameters (first 100 shown)`),
    h('table', {}, h('thead', {}, h('tr', {}, ...['Parameter', 'Title', 'Unit', 'Range', 'Value', 'Write', ''].map((t) => h('th', {}, t)))), body),
  );
  return box;
}
