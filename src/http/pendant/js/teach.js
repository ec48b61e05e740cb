// The teaching session against the simulated arm: where the arm is (joints and TCP, from the
// server), the routine being taught, the suggestion on offer, and the operator's actions —
// jog, Record, Accept, Accept next n, Adjust, Reject, Undo, Finish — each one call sequence on
// the REST API.
// The page (main.js) renders what this holds; nothing here touches the DOM.

import * as api from './api.js';
import { jogged } from './pose.js';

// Feedback the page gave or learned of, by prediction id, kept for the browser session so that
// a reload still knows it (the service takes feedback once per prediction and says so with a
// 409, which the page takes as the service's word).
const VERDICTS_KEY = 'nextpose-verdicts';

function storedVerdicts() {
  try {
    const kept = JSON.parse(sessionStorage.getItem(VERDICTS_KEY) || '{}');
    return new Map(Object.entries(kept).map(([id, v]) => [Number(id), String(v)]));
  } catch {
    return new Map();
  }
}

/** The suggestion an action was pressed on is no longer the one on offer: nothing is sent. */
export class Stale extends Error {
  constructor() {
    super('the suggestion on screen changed before the press was taken: nothing recorded, press again');
    this.code = 'stale';
  }
}

/** Joint vectors from `a` to `b` in `n` equal steps (both ends included). */
function interpolate(a, b, n) {
  return Array.from({ length: n + 1 }, (_, i) => a.map((v, j) => v + ((b[j] - v) * i) / n));
}

export class Session {
  constructor(view) {
    this.view = view;
    this.cell = null;
    this.routine = null; // RoutineDetail
    this.others = []; // waypoints of the program's other routines
    this.frames = null; // ArmFrames of where the arm is
    this.prediction = null;
    // The suggestion was rejected or is being adjusted: no longer on offer.
    this.dismissed = false;
    // Feedback given, by prediction id: an undo offers the same prediction again, and the
    // service takes feedback once per prediction (kept across a reload).
    this.verdicts = storedVerdicts();
    this.language = null; // the cell's program language (poses in numbers)
    this.adjusting = null;
    this.latencies = [];
    // What the look-ahead showed: suggestions ahead, and the first unreachable one (1-based).
    this.ahead = { count: 0, unreachable: 0 };
  }

  get joints() {
    return this.frames ? this.frames.joints : null;
  }

  get open() {
    return Boolean(this.routine && !this.routine.finished);
  }

  get offered() {
    return Boolean(this.prediction && this.prediction.offered && !this.dismissed);
  }

  /** The feedback already given on the suggestion on offer, if any. */
  get verdict() {
    return this.offered ? this.verdicts.get(this.prediction.id) : undefined;
  }

  /** The offered suggestion's joint solution when the arm reaches it. */
  get reachableSuggestion() {
    const r = this.offered ? this.prediction.reachability : null;
    return r && r.reachable && r.chosen ? r.chosen : null;
  }

  frameUrl(joints) {
    const q = joints ? `?joints=${joints.map((v) => v.toFixed(12)).join(',')}` : '';
    return `/v1/cells/${this.cell.id}/frames${q}`;
  }

  async moveTo(joints) {
    this.frames = await api.get(this.frameUrl(joints));
    this.view.drawArm(this.frames);
  }

  async setCell(cell, language = null) {
    this.cell = cell;
    this.language = language;
    this.routine = null;
    this.others = [];
    this.clearSuggestion();
    await this.moveTo(null);
  }

  /** No cell (the caller sees none): nothing to teach. */
  leaveCell() {
    this.cell = null;
    this.language = null;
    this.routine = null;
    this.others = [];
    this.frames = null;
    this.clearSuggestion();
    this.view.drawPaths([], []);
  }

  async setRoutine(detail, others) {
    this.routine = detail;
    this.others = others;
    this.adjusting = null;
    this.view.drawPaths(detail ? detail.waypoints : [], others);
    const last = detail && detail.waypoints.length ? detail.waypoints[detail.waypoints.length - 1] : null;
    if (last && last.joints && last.joints.length === 6) await this.moveTo(last.joints);
    if (this.open && detail.waypoints.length) {
      const set = await api.get(`/v1/routines/${detail.id}/prediction`);
      await this.showPrediction(set.predictions[0]);
    } else {
      this.clearSuggestion();
    }
  }

  async reloadRoutine() {
    this.routine = await api.get(`/v1/routines/${this.routine.id}`);
    this.view.drawPaths(this.routine.waypoints, this.others);
  }

  clearSuggestion() {
    this.prediction = null;
    this.dismissed = false;
    this.ahead = { count: 0, unreachable: 0 };
    this.view.hideGhost();
    this.view.drawAhead(null, []);
  }

  /** Shows a prediction: the ghost at the chosen joints, or why nothing is offered. */
  async showPrediction(p) {
    this.prediction = p || null;
    this.dismissed = false;
    if (!p || !p.offered || !p.pose) {
      this.view.hideGhost();
      this.view.drawAhead(null, []);
      return;
    }
    const reach = p.reachability;
    const reachable = !reach || reach.reachable;
    const frames = reach && reach.chosen ? await api.get(this.frameUrl(reach.chosen)) : null;
    this.view.showGhost(frames, p.pose, p.p_useful ?? p.phi, reachable);
  }

  /**
   * The next k suggestions (open-loop completion, following a row or a pallet's layers), drawn
   * as ghosts on a dotted path. The completion stops at the first suggestion not offered; when
   * that is because the arm cannot reach it (or it is offered flagged), it is drawn flagged.
   * Returns `{ count, unreachable }`: the suggestions ahead, and the 1-based place of the first
   * unreachable one (0: none).
   */
  async lookAhead(k) {
    this.ahead = { count: 0, unreachable: 0 };
    if (!this.open || !this.routine.waypoints.length) {
      this.view.drawAhead(null, []);
      return this.ahead;
    }
    const set = await api.get(`/v1/routines/${this.routine.id}/prediction?k=${k}`);
    const ahead = [];
    for (const p of set.predictions) {
      if (!p.pose) break;
      const unreachable =
        (p.reachability && p.reachability.reachable === false) ||
        (p.withheld && p.withheld.reason === 'unreachable');
      if (!p.offered && !unreachable) break;
      ahead.push({ pose: p.pose, reachable: !unreachable });
      if (unreachable) break;
    }
    const last = this.routine.waypoints[this.routine.waypoints.length - 1];
    this.view.drawAhead(last.pose, ahead);
    const flagged = ahead.findIndex((a) => !a.reachable);
    this.ahead = { count: ahead.length, unreachable: flagged + 1 };
    return this.ahead;
  }

  /** One jog step; the arm moves only where the server says it reaches. */
  async jog(axis, stepMm, stepDeg, frame) {
    const target = jogged(this.frames.tcp, axis, stepMm, stepDeg, frame);
    const reach = await api.post(`/v1/cells/${this.cell.id}/reach`, { pose: target, near: this.joints });
    if (!reach.reachable || !reach.chosen) {
      throw new Error(`cannot jog ${axis}: ${reach.unreachable ? reach.unreachable.message : 'no solution'}`);
    }
    await this.moveTo(reach.chosen);
  }

  /**
   * Appends a waypoint (the arm's pose and joints unless given) and shows the next suggestion.
   * It says which place the waypoint is to have (`seq`), so that the service stores it once
   * even when the request is sent again (it is, once, after a failure of the network: the
   * service answers a repeat with the waypoint it stored).
   */
  async append(motion, pose = this.frames.tcp, joints = this.joints) {
    const body = { pose, joints, motion };
    body.seq = this.routine.waypoints.length + 1;
    const path = `/v1/routines/${this.routine.id}/waypoints`;
    let taught;
    try {
      taught = await api.post(path, body);
    } catch (e) {
      if (e instanceof api.ApiError) throw e;
      taught = await api.post(path, body);
    }
    this.routine.waypoints.push(taught.waypoint);
    this.routine.finished = false;
    this.view.drawPaths(this.routine.waypoints, this.others);
    await this.showPrediction(taught.prediction);
    return taught;
  }

  /** Record: in the middle of an adjustment, the feedback says where the operator ended. */
  async record(motion) {
    const start = performance.now();
    if (this.adjusting) {
      await this.feedback(this.adjusting, 'adjusted', this.frames.tcp);
      this.adjusting = null;
    }
    await this.append(motion);
    const ms = performance.now() - start;
    this.latencies.push(ms);
    return ms;
  }

  /** Moves the arm to the suggestion, animated through joint space. */
  async goToSuggestion() {
    const to = this.reachableSuggestion;
    const steps = await Promise.all(interpolate(this.joints, to, 10).map((q) => api.get(this.frameUrl(q))));
    await this.view.animate(steps, (f) => this.view.drawArm(f));
    this.frames = steps[steps.length - 1];
  }

  remember(id, verdict) {
    this.verdicts.set(id, verdict);
    sessionStorage.setItem(VERDICTS_KEY, JSON.stringify(Object.fromEntries(this.verdicts)));
  }

  /**
   * Feedback on `p`, once: returns null when it is recorded now, or the verdict it already had
   * (known to the page, or a 409 from the service: given before, from this page before a
   * reload or from another pendant), which is then kept as the service has it.
   */
  async feedback(p, verdict, pose) {
    const known = this.verdicts.get(p.id);
    if (known !== undefined) return known;
    try {
      await api.post(`/v1/predictions/${p.id}/feedback`, pose ? { verdict, pose } : { verdict });
    } catch (e) {
      if (!(e instanceof api.ApiError) || e.status !== 409) throw e;
      const given = /\((accepted|adjusted|rejected)\)/.exec(e.message);
      this.remember(p.id, given ? given[1] : 'given');
      return this.verdicts.get(p.id);
    }
    this.remember(p.id, verdict);
    return null;
  }

  /** Throws Stale unless `shown` is the suggestion on offer. */
  check(shown) {
    if (!shown || shown !== this.prediction || this.dismissed || !shown.offered) throw new Stale();
  }

  /**
   * Accept the suggestion `shown` (the one on screen when pressed): its feedback once, the arm
   * goes there, and the waypoint is recorded at its pose and joints. Returns `{ before }`: the
   * verdict it already had, if any.
   */
  async accept(motion, shown) {
    this.check(shown);
    const joints = this.reachableSuggestion;
    if (!joints) throw new Error('the suggestion is out of the arm\'s reach');
    const before = await this.feedback(shown, 'accepted');
    await this.goToSuggestion();
    await this.append(motion, shown.pose, joints);
    return { before };
  }

  /**
   * Accept next n: the suggestion on offer and the ones after it, one by one, each recorded as
   * an accepted suggestion (its feedback, then the waypoint at its pose and joints), while the
   * next one is offered and the arm reaches it. The arm ends at the last; returns how many
   * were accepted.
   */
  async acceptNext(n, motion, shown) {
    this.check(shown);
    let accepted = 0;
    while (accepted < n && this.reachableSuggestion) {
      const p = this.prediction;
      const joints = this.reachableSuggestion;
      await this.feedback(p, 'accepted');
      await this.append(motion, p.pose, joints);
      accepted += 1;
    }
    const w = this.routine.waypoints;
    const last = w.length ? w[w.length - 1] : null;
    if (accepted && last && last.joints && last.joints.length === 6) await this.moveTo(last.joints);
    return accepted;
  }

  /** Adjust: the arm goes there; the next Record gives the feedback with the pose taught. */
  async adjust(shown) {
    this.check(shown);
    await this.goToSuggestion();
    this.adjusting = this.verdicts.has(shown.id) ? null : shown;
    this.dismissed = true;
    this.view.hideGhost();
  }

  /**
   * Reject the suggestion `shown`; it is set aside either way. Returns null, or the verdict it
   * already had (then nothing is recorded).
   */
  async reject(shown) {
    this.check(shown);
    const before = await this.feedback(shown, 'rejected');
    this.clearSuggestion();
    return before;
  }

  async undo() {
    const undone = await api.del(`/v1/routines/${this.routine.id}/waypoints/last`);
    this.adjusting = null;
    await this.reloadRoutine();
    const w = this.routine.waypoints;
    const last = w.length ? w[w.length - 1] : null;
    if (last && last.joints && last.joints.length === 6) await this.moveTo(last.joints);
    await this.showPrediction(undone.prediction);
    return undone.removed;
  }

  async finish() {
    const finished = await api.post(`/v1/routines/${this.routine.id}/finish`);
    this.adjusting = null;
    await this.reloadRoutine();
    this.clearSuggestion();
    return finished;
  }

  // ---- edits of the selected waypoint (any routine) ----

  async reteach(id) {
    await api.patch(`/v1/waypoints/${id}`, { pose: this.frames.tcp, joints: this.joints });
    await this.reloadRoutine();
  }

  async edit(id, changes) {
    await api.patch(`/v1/waypoints/${id}`, changes);
    await this.reloadRoutine();
  }

  async insert(id, side, motion) {
    await api.post(`/v1/waypoints/${id}/insert`, {
      side,
      waypoint: { pose: this.frames.tcp, joints: this.joints, motion },
    });
    await this.reloadRoutine();
  }

  async remove(id) {
    await api.del(`/v1/waypoints/${id}`);
    await this.reloadRoutine();
  }
}
