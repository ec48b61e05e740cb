// The pendant page: wires the DOM (pickers, waypoint list, jog pad, actions, keyboard, the
// token dialog, who is signed in) to the teaching session (teach.js) and the 3D view
// (scene.js). Every action runs one at a time; a failure (a 403 too) is shown in #status, never
// thrown, and cleared by the next action that succeeds. A press is taken once: while one is in
// flight the buttons that change anything are off and their keys do nothing, and an Accept
// carries the suggestion that was on screen when it was pressed. A control whose action the
// caller's role may not do is off (access.js).

import { allowed, describe, refusal } from './access.js';
import * as api from './api.js';
import { describePose, inNumbers } from './pose.js';
import { View } from './scene.js';
import { Session } from './teach.js';

const $ = (id) => document.getElementById(id);
const view = new View($('view3d'));
const session = new Session(view);
window.nextposeLatencies = session.latencies;
let selected = null; // id of the selected waypoint
let me = null; // who the token says the caller is (GET /v1/whoami); null until known
let starting = true; // the page's first load is under way
let displayed = null; // the suggestion on screen (rendered), which an Accept carries
let pressing = 0; // presses in flight: nothing else is taken meanwhile

// How many times the status was set: an action that succeeds without saying anything clears
// an error left by an earlier one.
let said = 0;
function status(text, level = 'info', code = '') {
  said += 1;
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

// One action at a time, in order; errors end up in #status, and an action that succeeds
// without a word of its own clears an error shown before it.
let queue = Promise.resolve();
function run(action) {
  queue = queue
    .then(async () => {
      const before = said;
      await action();
      if (said === before && $('status').dataset.level === 'error') status('');
    })
    .catch(report)
    .finally(render);
  return queue;
}

/**
 * A press of a control that changes something (or its key): taken once. While a press is in
 * flight every such control is off and a second press is dropped, so a double click or a key
 * pressed twice acts once; `fn` is given the suggestion on screen when it was pressed.
 */
function press(id, fn) {
  if (pressing > 0 || $(id).disabled) return null;
  const shown = displayed;
  pressing += 1;
  document.body.dataset.busy = String(pressing);
  render();
  return run(async () => {
    await fn(shown);
    // What the press changed is the program's newest revision.
    if ($('history').open) await refreshHistory();
  }).finally(() => {
    pressing -= 1;
    document.body.dataset.busy = String(pressing);
    render();
  });
}

// ---- the token ----

// The dialog checks a token with the service (`GET /v1/whoami` with it) before keeping it: a
// refused one (empty, unknown, revoked) says why, with the service's message. Closed without
// one (Escape, Cancel), the promise is refused and the page stays signed out, with Sign in to
// open the dialog again.
let asking = null;
function tokenDialog() {
  if (asking) return asking;
  asking = new Promise((resolve, reject) => {
    const dialog = $('token-dialog');
    const form = $('token-form');
    const error = $('token-error');
    let given = null;
    error.textContent = '';
    error.dataset.code = '';
    error.hidden = true;
    $('token-input').value = '';
    const submit = async (e) => {
      e.preventDefault();
      const secret = $('token-input').value.trim();
      $('token-submit').disabled = true;
      try {
        await api.whoIs(secret);
        given = secret;
        dialog.close();
      } catch (err) {
        error.textContent = `refused${err.status ? ` (${err.status})` : ''}: ${err.message || err}`;
        error.dataset.code = err.code || '';
        error.hidden = false;
      } finally {
        $('token-submit').disabled = false;
      }
    };
    const closed = () => {
      form.removeEventListener('submit', submit);
      dialog.removeEventListener('close', closed);
      asking = null;
      renderMe();
      if (given !== null) resolve(given);
      else reject(new api.ApiError(401, 'unauthorized', 'not signed in: press Sign in and enter the token'));
    };
    form.addEventListener('submit', submit);
    dialog.addEventListener('close', closed);
    dialog.showModal();
  });
  renderMe();
  return asking;
}
api.onTokenNeeded(tokenDialog);
$('token-cancel').addEventListener('click', () => $('token-dialog').close());

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
  el.title = me ? `${describe(me)} — who the token says you are` : 'not signed in';
  $('sign-out').hidden = !(me && me.authenticated);
  // Signed out (the dialog closed without a token, or a token refused): the way back in.
  $('sign-in').hidden = Boolean(me) || starting || asking !== null;
}

// Sign in, or Change token: the dialog; a token the service knows is kept and the page loads
// again as its caller (who it is, then its cells). Closed without one, nothing changes (Change
// token keeps the old token).
function signIn() {
  tokenDialog()
    .then((secret) => {
      api.use(secret);
      return run(start);
    })
    .catch((e) => {
      if (!me) report(e);
    });
}
$('sign-in').addEventListener('click', signIn);
$('sign-out').addEventListener('click', signIn);

// ---- rendering ----

// A long name never widens the page: a picker is as wide as the CSS lets it be, cut with an
// ellipsis, and its title (and each option's) is the whole name.
function options(select, items, value, label) {
  select.replaceChildren(
    ...items.map((item) => {
      const o = document.createElement('option');
      o.value = String(item.id ?? item.name);
      o.textContent = label(item);
      o.title = o.textContent;
      return o;
    }),
  );
  if (value != null) select.value = String(value);
  titleOf(select);
}

/** A picker's title: the whole of what it shows. */
function titleOf(select) {
  const o = select.selectedOptions[0];
  select.title = o ? o.textContent : '';
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
      name.className = 'name';
      name.textContent = `${w.seq}. ${w.name || 'p' + w.seq}`;
      name.title = name.textContent;
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
  const where = $('suggestion-pose');
  displayed = null;
  where.textContent = '';
  where.dataset.pose = '';
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
  displayed = p;
  const certainty = p.p_useful != null ? `p_useful ${p.p_useful.toFixed(2)}` : `φ ${p.phi.toFixed(2)}`;
  const before = session.verdict ? ` · ${session.verdict} before` : '';
  text.textContent = `${certainty}${p.expert ? ' · ' + p.expert : ''}${before}`;
  reason.textContent = reachable ? '' : `not reachable: ${reach.unreachable ? reach.unreachable.message : ''}`;
  if (p.pose) showPose(where, p.pose);
}

/** A pose in numbers in `el`, as the cell's program language writes it. */
function showPose(el, pose) {
  const n = inNumbers(pose, session.language);
  el.textContent = describePose(pose, session.language);
  el.dataset.notation = n.notation;
  el.dataset.pose = JSON.stringify([...n.position, ...n.orientation]);
}

/** Where the TCP is, in numbers. */
function renderTcp() {
  const el = $('tcp-pose');
  if (!session.frames) {
    el.textContent = '–';
    el.dataset.pose = '';
    return;
  }
  showPose(el, session.frames.tcp);
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
  const idle = pressing === 0;
  // Every control the role gates, then those that also depend on the session; while a press
  // is in flight, the presses are off.
  for (const el of document.querySelectorAll('[data-needs]')) able(el, idle || el.tagName !== 'BUTTON');
  able($('record'), idle && open && session.frames);
  able($('undo'), idle && open && n > 0);
  able($('finish'), idle && open && n > 0);
  able($('accept'), idle && session.reachableSuggestion);
  able($('accept-n'), idle && session.reachableSuggestion);
  able($('adjust'), idle && session.reachableSuggestion);
  able($('reject'), idle && session.offered && session.verdict === undefined);
  if (session.verdict !== undefined && !$('reject').title) {
    $('reject').title = `this suggestion already has feedback (${session.verdict}): the service takes one`;
  }
  able($('create-routine'), idle && $('program-select').value);
  able($('create-program'), idle && session.cell);
  able($('calib-apply'), idle && calibrationReady());
  able($('history-restore'), idle && history.chosen != null);
  const chosen = session.routine && session.routine.waypoints.find((w) => w.id === selected);
  for (const id of ['wp-reteach', 'wp-rename', 'wp-motion', 'wp-insert-before', 'wp-insert-after', 'wp-delete']) {
    able($(id), idle && chosen);
  }
  for (const b of document.querySelectorAll('[data-jog]')) b.disabled = !session.frames;
}

function render() {
  renderWaypoints();
  renderSuggestion();
  renderTcp();
  renderAhead();
  renderButtons();
  renderMe();
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
  else session.leaveCell();
}

async function chooseCell(id) {
  $('cell-select').value = String(id);
  titleOf($('cell-select'));
  const cell = await api.get(`/v1/cells/${id}`);
  await session.setCell(cell, await languageOf(cell));
  await loadPrograms(null);
  await refreshStats();
}

/**
 * The language the cell's programs are written in: its arm's controller's first
 * (`GET /v1/robots/{name}`: `rapid`, `krl`, `fanuc`, `urscript`); null for an arm without one
 * or one no longer installed (poses are then shown as quaternions).
 */
async function languageOf(cell) {
  const robot = cell.settings && cell.settings.robot;
  if (!robot) return null;
  try {
    const arm = await api.get(`/v1/robots/${encodeURIComponent(robot)}`);
    return arm.languages && arm.languages.length ? arm.languages[0] : null;
  } catch (e) {
    if (e instanceof api.ApiError && e.status === 404) return null;
    throw e;
  }
}

async function loadPrograms(select) {
  const programs = await api.get(`/v1/cells/${session.cell.id}/programs`);
  options($('program-select'), programs, select, (p) => p.name);
  const id = select ?? (programs.length ? programs[programs.length - 1].id : null);
  if (id != null) await loadRoutines(id, null);
  else {
    options($('routine-select'), [], null, () => '');
    await session.setRoutine(null, []);
    history.chosen = null;
    await refreshHistory();
  }
}

function routineLabel(r) {
  return `${r.name || 'routine ' + r.position}${r.finished ? '' : ' (open)'}`;
}

async function loadRoutines(programId, select) {
  $('program-select').value = String(programId);
  titleOf($('program-select'));
  history.chosen = null;
  await refreshHistory();
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
  titleOf($('routine-select'));
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
  async accept(shown) {
    const { before } = await session.accept(motion(), shown);
    status(
      before
        ? `accepted: the waypoint is recorded (the suggestion already had feedback: ${before})`
        : 'accepted: the waypoint is recorded',
    );
    await afterTeaching();
  },
  async 'accept-n'(shown) {
    const n = Math.max(1, Math.min(20, Number($('accept-n-count').value) || 1));
    const done = await session.acceptNext(n, motion(), shown);
    status(done < n ? `accepted ${done} of ${n}: the next is not on offer` : `accepted ${done}`);
    await afterTeaching();
  },
  async adjust(shown) {
    await session.adjust(shown);
    status('adjusting: jog to the right place, then Record');
  },
  async reject(shown) {
    const before = await session.reject(shown);
    status(
      before
        ? `not rejected: the suggestion already has feedback (${before}); it is set aside`
        : 'rejected',
    );
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
  $(name).addEventListener('click', () => press(name, action));
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
  press('create-cell', async () => {
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
  press('create-program', async () => {
    const p = await api.post(`/v1/cells/${session.cell.id}/programs`, { name: $('new-program-name').value.trim() });
    await loadPrograms(p.id);
    $('setup').open = false;
    status(`program ${p.name} created`);
  }),
);
$('create-routine').addEventListener('click', () =>
  press('create-routine', async () => {
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
  press('calib-record', async () => {
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
  press('calib-apply', async () => {
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
  // A name, or none: an empty name clears it (the API's `null`), and the status says so.
  'wp-rename': async () => {
    const w = session.routine.waypoints.find((x) => x.id === selected);
    const given = window.prompt(`Name of waypoint ${w.seq} (empty: no name)`, w.name || '');
    if (given === null) return;
    const name = given.trim();
    await session.edit(selected, { name: name || null });
    status(name ? `waypoint ${w.seq} is named ${name}` : `waypoint ${w.seq}'s name is cleared`);
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
  $(id).addEventListener('click', () => press(id, edit));
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

// ---- the program's history: its revisions, a revision against now, a restore ----

const history = {
  program: null, // the program whose revisions are listed
  revisions: [], // newest first
  chosen: null, // the revision picked
};

const CHANGES = {
  waypoint_added: 'waypoint added',
  waypoint_removed: 'waypoint removed',
  waypoint_modified: 'waypoint changed',
  routine_added: 'routine added',
  routine_removed: 'routine removed',
  routine_renamed: 'routine renamed',
  routine_moved: 'routine moved',
  routine_finished: 'routine finished',
  routines_reordered: 'routines reordered',
};

/** What a revision changed, in words: `waypoint 52 changed`, `routine 7 finished`. */
function changesOf(revision) {
  if (!revision.changes.length) return revision.revision === 0 ? 'the program as its history began' : 'no change';
  return revision.changes
    .map((c) => {
      const what = CHANGES[c.change] || c.change;
      const [kind, ...rest] = what.split(' ');
      const id = kind === 'waypoint' ? c.waypoint_id : kind === 'routine' ? c.routine_id : null;
      return id == null ? what : `${kind} ${id} ${rest.join(' ')}`;
    })
    .join(', ');
}

/** When, as the service wrote it (UTC), to the second. */
const when = (at) => (at ? at.replace('T', ' ').replace(/\.\d+Z$|Z$/, '') + ' UTC' : '');

/** Lists the selected program's revisions (when the history is open). */
async function refreshHistory() {
  const programId = Number($('program-select').value) || null;
  if (programId !== history.program) {
    history.chosen = null;
    history.revisions = [];
  }
  history.program = programId;
  if (!$('history').open || programId == null) {
    renderHistory();
    return;
  }
  const h = await api.get(`/v1/programs/${programId}/history?limit=50`);
  if (history.program !== programId) return;
  history.revisions = h.revisions;
  if (!h.revisions.some((r) => r.revision === history.chosen)) history.chosen = null;
  renderHistory();
  if (history.chosen != null) await showDiff(history.chosen);
}

function renderHistory() {
  const list = $('revisions');
  list.dataset.program = history.program == null ? '' : String(history.program);
  list.replaceChildren(
    ...history.revisions.map((r) => {
      const li = document.createElement('li');
      li.dataset.revision = String(r.revision);
      li.setAttribute('aria-selected', String(r.revision === history.chosen));
      const head = document.createElement('span');
      head.className = 'who';
      head.textContent = `r${r.revision} · ${r.token || '—'} · ${when(r.at)}`;
      const what = document.createElement('span');
      what.className = 'what';
      what.textContent = changesOf(r);
      li.title = `${head.textContent}\n${what.textContent}${r.operation ? `\n${r.operation}` : ''}`;
      li.append(head, what);
      li.addEventListener('click', () => run(() => chooseRevision(r.revision)));
      return li;
    }),
  );
  if (history.chosen == null) {
    $('diff').textContent = history.revisions.length ? 'pick a revision to compare it with now' : '';
    $('diff').dataset.revision = '';
  }
  renderButtons();
}

async function chooseRevision(revision) {
  history.chosen = history.chosen === revision ? null : revision;
  renderHistory();
  if (history.chosen != null) await showDiff(history.chosen);
}

/** A revision against the program now: what was added, removed and changed (mm and degrees). */
async function showDiff(revision) {
  const programId = history.program;
  const d = await api.get(`/v1/programs/${programId}/diff?from=${revision}`);
  if (history.program !== programId || history.chosen !== revision) return;
  const box = $('diff');
  box.dataset.revision = String(revision);
  box.dataset.to = String(d.to);
  const lines = [];
  const line = (text, kind) => {
    const li = document.createElement('li');
    li.textContent = text;
    li.dataset.kind = kind;
    li.title = text;
    lines.push(li);
  };
  for (const w of d.waypoints_changed) {
    const fields = w.fields.length ? ` (${w.fields.join(', ')})` : '';
    const seq = w.seq_from === w.seq_to ? `${w.seq_to}` : `${w.seq_from} → ${w.seq_to}`;
    line(
      `waypoint ${seq} of routine ${w.routine_id}: moved ${w.moved_mm.toFixed(1)} mm, turned ${w.turned_degrees.toFixed(1)}°${fields}`,
      'changed',
    );
  }
  for (const w of d.waypoints_added) line(`waypoint ${w.seq} of routine ${w.routine_id} added since`, 'added');
  for (const w of d.waypoints_removed) line(`waypoint ${w.seq} of routine ${w.routine_id} removed since`, 'removed');
  for (const r of d.routines_added) line(`routine ${r.name || r.position} added since (${r.waypoints} waypoints)`, 'added');
  for (const r of d.routines_removed) line(`routine ${r.name || r.position} removed since (${r.waypoints} waypoints)`, 'removed');
  for (const r of d.routines_changed) {
    const name = r.name_from === r.name_to ? '' : ` renamed ${r.name_from || '–'} → ${r.name_to || '–'}`;
    const place = r.position_from === r.position_to ? '' : ` moved ${r.position_from} → ${r.position_to}`;
    line(`routine ${r.id}${name}${place}`, 'changed');
  }
  const head = document.createElement('p');
  head.textContent = lines.length ? `r${revision} → now (r${d.to}):` : `r${revision} is the program as it is now`;
  const list = document.createElement('ul');
  list.append(...lines);
  box.replaceChildren(head, list);
}

$('history').addEventListener('toggle', () => run(refreshHistory));
$('history-restore').addEventListener('click', () =>
  press('history-restore', async () => {
    const programId = history.program;
    const revision = history.chosen;
    const r = await api.post(`/v1/programs/${programId}/restore`, { revision });
    status(
      r.changed
        ? `restored revision ${r.restored}: the program is as it was then (now revision ${r.revision})`
        : `the program already is as at revision ${r.restored}: nothing changed`,
    );
    const routine = session.routine && session.routine.id;
    const routines = await api.get(`/v1/programs/${programId}/routines`);
    const keep = routines.some((x) => x.id === routine) ? routine : null;
    await loadRoutines(programId, keep);
    await refreshStats();
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
    press(action, actions[action]);
  }
});

// ---- start ----

run(async () => {
  try {
    await start();
  } finally {
    starting = false;
    renderMe();
  }
});

async function start() {
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
}
