// Parameter sets: list, view, diff against a drive (changed rows highlighted), dry run and
// apply with the result per drive and parameter (Operation of ApplyParameterSet).
import { h, showError } from '../ui.js';
import { get, post, can, short } from '../api.js';

export async function render(root) {
  const [{ parameterSets: sets = [], parameter_sets: sets2 = [] }, { drives = [] }] = await Promise.all([
    get('/v1/parameterSets'),
    get('/v1/drives'),
  ]);
  const list = [...sets, ...sets2];
  const detail = h('div');
  root.append(
    h('h2', {}, 'Parameter sets'),
    h(
      'table',
      {},
      h('thead', {}, h('tr', {}, ...['Name', 'Family', 'Version', 'Parameters', 'Author'].map((t) => h('th', {}, t)))),
      h(
        'tbody',
        {},
        list.map((s) =>
          h(
            'tr',
            { 'data-testid': `pset-row-${short(s.name)}`, class: 'click', onclick: () => show(detail, s, drives) },
            h('td', {}, short(s.name)),
            h('td', {}, s.family),
            h('td', {}, String(s.version)),
            h('td', {}, String((s.parameters || []).length)),
            h('td', {}, s.author || ''),
          ),
        ),
      ),
    ),
    list.length ? '' : h('p', {}, 'No parameter sets stored.'),
    detail,
  );
}

function show(detail, set, drives) {
  const name = short(set.name);
  const mine = drives.filter((d) => d.family === set.family);
  const select = h('select', { 'data-testid': 'pset-drive' }, mine.map((d) => h('option', { value: short(d.name) }, short(d.name))));
  const out = h('div');
  const msg = h('div');
  const engineer = can('engineer');

  const diff = async () => {
    showError(msg, null);
    try {
      const r = await post(`/v1/parameterSets/${name}:diff`, { drive: `drives/${select.value}` });
      out.replaceChildren(
        h('p', {}, `${r.differing || 0} differ`),
        h(
          'table',
          {},
          h('thead', {}, h('tr', {}, ...['Parameter', 'Set', 'Drive'].map((t) => h('th', {}, t)))),
          h(
            'tbody',
            {},
            (r.parameters || []).map((p) =>
              h(
                'tr',
                { 'data-testid': 'diff-row', class: p.differs ? 'changed' : '' },
                h('td', {}, p.parameter),
                h('td', {}, p.in_a === false ? '—' : String(p.a ?? '')),
                h('td', {}, p.in_b === false ? '—' : String(p.b ?? '')),
              ),
            ),
          ),
        ),
      );
    } catch (e) {
      showError(msg, e);
    }
  };

  const apply = (dry) => async () => {
    showError(msg, null);
    try {
      let op = await post(`/v1/parameterSets/${name}:apply`, { drives: [`drives/${select.value}`], dry_run: dry });
      while (!op.done) {
        await new Promise((r) => setTimeout(r, 300));
        op = await get(`/v1/${op.name}`);
      }
      out.replaceChildren(result(op));
    } catch (e) {
      showError(msg, e);
    }
  };

  detail.replaceChildren(
    h(
      'div',
      { class: 'card' },
      h('h3', {}, `${name} v${set.version}`, h('small', {}, ` ${set.family}${set.description ? ` — ${set.description}` : ''}`)),
      h(
        'table',
        {},
        h('thead', {}, h('tr', {}, h('th', {}, 'Parameter'), h('th', {}, 'Value'))),
        h('tbody', {}, (set.parameters || []).map((p) => h('tr', {}, h('td', {}, p.parameter), h('td', {}, String(p.value))))),
      ),
      h(
        'div',
        { class: 'row' },
        'Drive ',
        select,
        ' ',
        h('button', { 'data-testid': 'btn-diff', onclick: diff }, 'Diff'),
        h('button', { 'data-testid': 'btn-dry-run', onclick: apply(true), disabled: !engineer, hidden: !engineer }, 'Dry run'),
        h('button', { 'data-testid': 'btn-apply', onclick: apply(false), disabled: !engineer, hidden: !engineer }, 'Apply'),
      ),
      msg,
      out,
    ),
  );
}

// Per drive: its state, then each parameter written (or the one that failed and why).
function result(op) {
  return h(
    'div',
    { 'data-testid': 'apply-result' },
    h('p', {}, `${op.dry_run ? 'Dry run' : 'Apply'} ${short(op.name)}: ${op.state}`),
    (op.drives || []).map((d) =>
      h(
        'div',
        {},
        h('h4', {}, `${short(d.drive)}: ${d.state}`),
        d.error ? h('p', { class: 'error' }, `${d.failed_parameter || ''} ${d.error}`) : '',
        h(
          'table',
          {},
          h('thead', {}, h('tr', {}, h('th', {}, 'Parameter'), h('th', {}, 'Before'), h('th', {}, 'Written'))),
          h(
            'tbody',
            {},
            (d.written || []).map((w) => {
              const before = (d.pre_image || []).find((p) => p.parameter === w.parameter);
              return h('tr', {}, h('td', {}, w.parameter), h('td', {}, before ? String(before.value) : ''), h('td', {}, String(w.value)));
            }),
          ),
        ),
      ),
    ),
  );
}
