// The pendant page: wires the DOM (pickers, waypoint list, jog pad, actions, keyboard, the
// token dialog, who is signed in) to the teaching session (teach.js) and the 3D view
// (scene.js). Every action runs one at a time; a failure (a 403 too) is shown in #status, never
// thrown. A control whose action the caller's role may not do is off (access.js).

import { allowed, describe, refusal } from './access.js';
import * as api from './api.js';
import { View } from './scene.js';
import { Session } from './teach.js';

const $ = (id) => document.getElementById(id);
const view = new View($('view3d'));
const session = new Session(view);
window.nextposeLatencies = session.latencies;
let selected = null; // id of the selected waypoint
let me = null; // who the token says the caller is (GET /v1/whoami); null until known

function status(text, level = 'info', code = '') {
  const s = $('status');
  s.textContent = text;
  s.dataset.level = level;
  s.dataset.code = code;
  s.title = text;
}

/** Shows a failure: the service's message (a 403 says which role or cell it needed). */
function report(e) {
  const message = e.message || String(e);
  status(e.status === 403 ? `not allowed: ${message}` : message, 'error', e.code || '');
}

// One action at a time, in order; errors end up in #status.
let queue = Promise.resolve();
function run(action) {
  queue = queue.then(action).catch(report).finally(render);
  return queue;
}

// ---- the token ----

let asking = null;
api.onTokenNeeded(() => {
  if (!asking) {
    asking = new Promise((resolve) => {
      const dialog = $('token-dialog');
      $('token-form').addEventListener(
        'submit',
        () => {
          asking = null;
          resolve($('token-input').value.trim());
        },
        { once: true },
      );
      dialog.showModal();
    });
  }
  return asking;
});

// ---- who is signed in ----

let meLoading = null;
/** Asks the service who the token is, then shows it and greys out what it may not do. */
function loadMe() {
  meLoading = api.get('/v1/whoami').then((answer) => {
    me = answer;
    renderMe();
    render();
  });
  return meLoading;
}

// Another token (the dialog after a 401): another caller, perhaps another role.
api.onTokenChanged(() => {
  me = null;
  renderMe();
  render();
  loadMe().catch(report);
});

function renderMe() {
  const el = $('signed-in');
  el.dataset.role = me ? me.role : '';
  el.dataset.name = me ? me.name : '';
  el.dataset.cells = me && me.cells ? me.cells.join(',') : '';
  el.textContent = me ? describe(me) : 'not signed in';
  $('sign-out').hidden = !(me && me.authenticated);
}

// Sign out: forget the token; the page starts again and asks for one.
$('sign-out').addEventListener('click', () => {
  api.forget();
  window.location.reload();
});

// ---- rendering ----

function options(select, items, value, label) {
  select.replaceChildren(
    ...items.map((item) => {
      const o = document.createElement('option');
      o.value = String(item.id ?? item.name);
      o.textContent = label(item);
      return o;
    }),
  );
  if (value != null) select.value = String(value);
}

function renderWaypoints() {
  const list = $('waypoints');
  const waypoints = session.routine ? session.routine.waypoints : [];
  list.replaceChildren(
    ...waypoints.map((w) => {
      const li = document.createElement('li');
      li.dataset.seq = String(w.seq);
      li.dataset.id = String(w.id);
      li.dataset.reachable = w.reachable == null ? 'unknown' : String(w.reachable);
      li.setAttribute('aria-selected', String(w.id === selected));
      const name = document.createElement('span');
      name.textContent = `${w.seq}. ${w.name || 'p' + w.seq}`;
      const motion = document.createElement('span');
      motion.className = 'motion';
      motion.textContent = w.motion || 'linear';
      const reach = document.createElement('span');
      reach.className = 'reach';
      reach.textContent = w.reachable === false ? 'unreachable' : w.reachable ? 'reachable' : '';
      li.append(name, motion, reach);
      li.addEventListener('click', () => {
        selected = selected === w.id ? null : w.id;
        render();
      });
      return li;
    }),
  );
}

function renderSuggestion() {
  const box = $('suggestion');
  const p = session.prediction;
  const text = $('suggestion-text');
  const reason = $('suggestion-reason');
  if (!p || session.dismissed) {
    box.dataset.state = 'none';
    box.dataset.predictionId = '';
    text.textContent = session.adjusting ? 'adjusting: jog, then Record' : 'none';
    reason.textContent = '';
    return;
  }
  if (!p.offered) {
    box.dataset.state = 'withheld';
    box.dataset.predictionId = '';
    text.textContent = 'withheld';
    reason.textContent = p.withheld ? p.withheld.message : '';
    return;
  }
  const reach = p.reachability;
  const reachable = !reach || reach.reachable;
  box.dataset.state = reachable ? 'offered' : 'unreachable';
  box.dataset.predictionId = String(p.id);
  const certainty = p.p_useful != null ? `p_useful ${p.p_useful.toFixed(2)}` : `φ ${p.phi.toFixed(2)}`;
  const before = session.verdict ? ` · ${session.verdict} before` : '';
  text.textContent = `${certainty}${p.expert ? ' · ' + p.expert : ''}${before}`;
  reason.textContent = reachable ? '' : `not reachable: ${reach.unreachable ? reach.unreachable.message : ''}`;
}

/**
 * Turns a control on when `when` holds and the caller may do its action (`data-needs`), off
 * otherwise; a control the role may not use says in its title what it needs.
 */
function able(el, when) {
  const why = el.dataset.needs ? refusal(me, el.dataset.needs, el.dataset.scope) : null;
  el.disabled = !when || why !== null;
  if (el.dataset.help === undefined) el.dataset.help = el.title;
  const help = el.dataset.help;
  el.title = why === null ? help : help ? `${why} — ${help}` : why;
}

function renderButtons() {
  const open = session.open;
  const n = session.routine ? session.routine.waypoints.length : 0;
  // Every control the role gates, then those that also depend on the session.
  for (const el of document.querySelectorAll('[data-needs]')) able(el, true);
  able($('record'), open && session.frames);
  able($('undo'), open && n > 0);
  able($('finish'), open && n > 0);
  able($('accept'), session.reachableSuggestion);
  able($('accept-n'), session.reachableSuggestion);
  able($('adjust'), session.reachableSuggestion);
  able($('reject'), session.offered && session.verdict === undefined);
  able($('create-routine'), $('program-select').value);
  able($('create-program'), session.cell);
  able($('calib-apply'), calibrationReady());
  const chosen = session.routine && session.routine.waypoints.find((w) => w.id === selected);
  for (const id of ['wp-reteach', 'wp-rename', 'wp-motion', 'wp-insert-before', 'wp-insert-after', 'wp-delete']) {
    able($(id), chosen);
  }
  for (const b of document.querySelectorAll('[data-jog]')) b.disabled = !session.frames;
}

function render() {
  renderWaypoints();
  renderSuggestion();
  renderAhead();
  renderButtons();
}

async function refreshStats() {
  if (!session.cell) return;
  const s = await api.get(`/v1/cells/${session.cell.id}/stats`);
  const set = (k, v) => {
    document.querySelector(`#stats [data-stat=${k}]`).textContent = String(v);
  };
  for (const k of ['offered', 'accepted', 'adjusted', 'rejected']) set(k, s.feedback[k]);
  set('states', s.model.states);
  const t = s.teaching;
  const how = (learned) => (learned ? ' (learned)' : ' (set)');
  set('noise', `${t.noise.mm.toFixed(1)} mm${how(t.noise_learned)}`);
  set('tolerance', `${t.tolerance.mm.toFixed(1)} mm${how(t.tolerance_learned)}`);
  set(
    'threshold',
    t.offer_threshold == null
      ? 'confidence gate'
      : `${t.offer_threshold.toFixed(2)}${t.threshold_steered ? ' (steered)' : ' (set)'}`,
  );
}

// ---- pickers ----

async function loadCells(select) {
  const cells = await api.get('/v1/cells');
  options($('cell-select'), cells, select, (c) => c.name);
  const id = select ?? (cells.length ? cells[cells.length - 1].id : null);
  if (id != null) await chooseCell(id);
}

async function chooseCell(id) {
  $('cell-select').value = String(id);
  const cell = await api.get(`/v1/cells/${id}`);
  await session.setCell(cell);
  await loadPrograms(null);
  await refreshStats();
}

async function loadPrograms(select) {
  const programs = await api.get(`/v1/cells/${session.cell.id}/programs`);
  options($('program-select'), programs, select, (p) => p.name);
  const id = select ?? (programs.length ? programs[programs.length - 1].id : null);
  if (id != null) await loadRoutines(id, null);
  else {
    options($('routine-select'), [], null, () => '');
    await session.setRoutine(null, []);
  }
}

function routineLabel(r) {
  return `${r.name || 'routine ' + r.position}${r.finished ? '' : ' (open)'}`;
}

async function loadRoutines(programId, select) {
  $('program-select').value = String(programId);
  const routines = await api.get(`/v1/programs/${programId}/routines`);
  options($('routine-select'), routines, select, routineLabel);
  const open = routines.find((r) => !r.finished);
  const id = select ?? (open ? open.id : routines.length ? routines[routines.length - 1].id : null);
  await chooseRoutine(id, routines);
}

async function chooseRoutine(id, routines) {
  selected = null;
  if (id == null) return session.setRoutine(null, []);
  $('routine-select').value = String(id);
  const detail = await api.get(`/v1/routines/${id}`);
  const others = await Promise.all(
    routines
      .filter((r) => r.id !== id)
      .slice(-10)
      .map((r) => api.get(`/v1/routines/${r.id}`).then((d) => d.waypoints)),
  );
  await session.setRoutine(detail, others);
}

async function reloadRoutinePicker() {
  const programId = Number($('program-select').value);
  const routines = await api.get(`/v1/programs/${programId}/routines`);
  options($('routine-select'), routines, session.routine && session.routine.id, routineLabel);
}

// ---- actions ----

function motion() {
  return $('motion').value;
}

async function afterTeaching() {
  if ($('show-path').checked) await session.lookAhead(Number($('lookahead-k').value) || 5);
  renderAhead();
  await refreshStats();
}

/** How many suggestions the look-ahead shows, and the first the arm cannot reach. */
function renderAhead() {
  const el = $('ahead');
  const { count, unreachable } = $('show-path').checked ? session.ahead : { count: 0, unreachable: 0 };
  el.dataset.count = String(count);
  el.dataset.unreachable = unreachable ? String(unreachable) : '';
  el.textContent = !$('show-path').checked
    ? 'ahead: –'
    : `ahead: ${count}${unreachable ? ` · #${unreachable} out of reach` : ''}`;
}

const actions = {
  async record() {
    const ms = await session.record(motion());
    const l = $('latency');
    l.textContent = `Record → suggestion: ${Math.round(ms)} ms`;
    l.dataset.ms = String(ms);
    l.dataset.count = String(session.latencies.length);
    await afterTeaching();
  },
  async accept() {
    await session.accept(motion());
    status('accepted: the waypoint is recorded');
    await afterTeaching();
  },
  async 'accept-n'() {
    const n = Math.max(1, Math.min(20, Number($('accept-n-count').value) || 1));
    const done = await session.acceptNext(n, motion());
    status(done < n ? `accepted ${done} of ${n}: the next is not on offer` : `accepted ${done}`);
    await afterTeaching();
  },
  async adjust() {
    await session.adjust();
    status('adjusting: jog to the right place, then Record');
  },
  async reject() {
    await session.reject();
    status('rejected');
    await refreshStats();
  },
  async undo() {
    const removed = await session.undo();
    status(`undone: waypoint ${removed.seq}`);
    await afterTeaching();
  },
  async finish() {
    const f = await session.finish();
    status(`finished; the model has ${f.model.states} states`);
    await reloadRoutinePicker();
    await refreshStats();
  },
};

for (const [name, action] of Object.entries(actions)) {
  $(name).addEventListener('click', () => run(action));
}

function jog(axis) {
  return run(() =>
    session.jog(axis, Number($('jog-step').value) || 1, Number($('jog-step-deg').value) || 1, $('jog-frame').value),
  );
}
for (const b of document.querySelectorAll('[data-jog]')) {
  b.addEventListener('click', () => jog(b.dataset.jog));
}

$('cell-select').addEventListener('change', (e) => run(() => chooseCell(Number(e.target.value))));
$('program-select').addEventListener('change', (e) => run(() => loadRoutines(Number(e.target.value), null)));
$('routine-select').addEventListener('change', (e) =>
  run(async () => {
    const programId = Number($('program-select').value);
    const routines = await api.get(`/v1/programs/${programId}/routines`);
    await chooseRoutine(Number(e.target.value), routines);
  }),
);

$('create-cell').addEventListener('click', () =>
  run(async () => {
    const name = $('new-cell-name').value.trim();
    const cell = await api.post('/v1/cells', {
      name,
      settings: { robot: $('new-cell-robot').value, reach_policy: $('new-cell-policy').value },
    });
    await loadCells(cell.id);
    status(`cell ${cell.name} created`);
  }),
);
$('create-program').addEventListener('click', () =>
  run(async () => {
    const p = await api.post(`/v1/cells/${session.cell.id}/programs`, { name: $('new-program-name').value.trim() });
    await loadPrograms(p.id);
    $('setup').open = false;
    status(`program ${p.name} created`);
  }),
);
$('create-routine').addEventListener('click', () =>
  run(async () => {
    const programId = Number($('program-select').value);
    const r = await api.post(`/v1/programs/${programId}/routines`, {});
    await loadRoutines(programId, r.id);
    status(`routine ${r.position} started`);
  }),
);

// ---- calibration: one point recorded several times sets the cell's noise ----

const calibration = [];
let calibrationCell = null; // the cell the recorded points are of
function calibrationReady() {
  return calibration.length >= 3 && Boolean(session.cell);
}
function renderCalibration() {
  $('calib-count').textContent = `${calibration.length} recorded`;
  $('calib-count').dataset.count = String(calibration.length);
  able($('calib-apply'), calibrationReady());
}
$('calib-record').addEventListener('click', () =>
  run(async () => {
    if (!session.frames) throw new Error('no arm pose yet: choose a cell');
    if (calibrationCell !== session.cell.id) calibration.length = 0;
    calibrationCell = session.cell.id;
    calibration.push(session.frames.tcp);
    renderCalibration();
  }),
);
$('calib-clear').addEventListener('click', () => {
  calibration.length = 0;
  renderCalibration();
});
$('calib-apply').addEventListener('click', () =>
  run(async () => {
    if (calibrationCell !== session.cell.id) throw new Error('the points were recorded in another cell: clear them');
    const cell = await api.post(`/v1/cells/${session.cell.id}/calibration`, { poses: calibration });
    calibration.length = 0;
    renderCalibration();
    await refreshStats();
    status(`noise set: ${cell.settings.noise.mm.toFixed(2)} mm per axis`);
  }),
);

const edits = {
  'wp-reteach': () => session.reteach(selected),
  'wp-rename': () => {
    const name = window.prompt('Waypoint name');
    return name ? session.edit(selected, { name }) : null;
  },
  'wp-motion': () => {
    const w = session.routine.waypoints.find((x) => x.id === selected);
    return session.edit(selected, { motion: w.motion === 'joint' ? 'linear' : 'joint' });
  },
  'wp-insert-before': () => session.insert(selected, 'before', motion()),
  'wp-insert-after': () => session.insert(selected, 'after', motion()),
  'wp-delete': async () => {
    await session.remove(selected);
    selected = null;
  },
};
for (const [id, edit] of Object.entries(edits)) {
  $(id).addEventListener('click', () => run(edit));
}

$('view-top').addEventListener('click', () => view.setView('top'));
$('view-front').addEventListener('click', () => view.setView('front'));
$('view-side').addEventListener('click', () => view.setView('side'));
$('view-fit').addEventListener('click', () => view.fit());
$('show-path').addEventListener('change', () =>
  run(async () => {
    if ($('show-path').checked) await session.lookAhead(Number($('lookahead-k').value) || 5);
    else view.drawAhead(null, []);
    renderAhead();
  }),
);

// ---- keyboard ----

const KEYS = {
  r: 'record', Enter: 'record', a: 'accept', n: 'accept-n', d: 'adjust', x: 'reject', u: 'undo', Backspace: 'undo', f: 'finish',
};
const JOG_KEYS = {
  ArrowRight: 'x+', ArrowLeft: 'x-', ArrowUp: 'y+', ArrowDown: 'y-', PageUp: 'z+', PageDown: 'z-',
};
document.addEventListener('keydown', (e) => {
  const t = e.target;
  if (t instanceof HTMLInputElement || t instanceof HTMLSelectElement || t instanceof HTMLTextAreaElement) return;
  if (e.ctrlKey || e.metaKey || e.altKey) return;
  const jogAxis = JOG_KEYS[e.key];
  if (jogAxis) {
    e.preventDefault();
    if (!session.frames) return;
    jog(e.shiftKey ? 'r' + jogAxis : jogAxis);
    return;
  }
  const action = KEYS[e.key.length === 1 ? e.key.toLowerCase() : e.key];
  if (action && !$(action).disabled) {
    e.preventDefault();
    run(actions[action]);
  }
});

// ---- start ----

run(async () => {
  const health = await api.get('/healthz');
  if (health.token_required && !api.hasToken()) {
    // Ask before the first guarded call, so no request is refused (the new token loads who
    // it is).
    await api.ask();
  }
  // Who is calling, before anything is offered: the controls follow the role.
  await (meLoading || loadMe());
  const robots = await api.get('/v1/robots');
  options($('new-cell-robot'), robots, 'abb_irb140', (r) => (r.product ? `${r.name} (${r.product})` : r.name));
  await loadCells(null);
  if (!session.cell) {
    if (allowed(me, 'edit', 'service')) {
      $('setup').open = true;
      status('create a cell to start');
    } else {
      status('no cell to teach in yet: an engineer creates one');
    }
  }
});
