// Pose algebra of the page (no arm kinematics: joints come from the server). A pose is the
// API's {x, y, z, qw, qx, qy, qz}: mm and a unit quaternion, in the cell's work frame.

import { Quaternion, Vector3 } from '../vendor/three/three.min.js';

export const AXES = {
  x: new Vector3(1, 0, 0),
  y: new Vector3(0, 1, 0),
  z: new Vector3(0, 0, 1),
};

export function quaternionOf(p) {
  return new Quaternion(p.qx, p.qy, p.qz, p.qw).normalize();
}

export function positionOf(p) {
  return new Vector3(p.x, p.y, p.z);
}

export function poseOf(position, quaternion) {
  const q = quaternion.clone().normalize();
  return { x: position.x, y: position.y, z: position.z, qw: q.w, qx: q.x, qy: q.y, qz: q.z };
}

/**
 * One jog step from `pose`: `axis` is `x+`, `rz-`, …; translations by `stepMm`, rotations by
 * `stepDeg` about the TCP. In the work frame the axes are the work frame's; in the tool frame
 * they are the TCP's own.
 */
export function jogged(pose, axis, stepMm, stepDeg, frame) {
  const rotate = axis.startsWith('r');
  const name = rotate ? axis[1] : axis[0];
  const sign = axis.endsWith('-') ? -1 : 1;
  const q = quaternionOf(pose);
  const p = positionOf(pose);
  const direction = AXES[name].clone();
  if (!rotate) {
    if (frame === 'tool') direction.applyQuaternion(q);
    return poseOf(p.add(direction.multiplyScalar(sign * stepMm)), q);
  }
  const turn = new Quaternion().setFromAxisAngle(direction, (sign * stepDeg * Math.PI) / 180);
  const turned = frame === 'tool' ? q.clone().multiply(turn) : turn.multiply(q);
  return poseOf(p, turned);
}

export function distanceMm(a, b) {
  return positionOf(a).distanceTo(positionOf(b));
}

// ---- a pose in numbers, as the cell's program language writes it ----
// The conventions of the exporters (src/export/): RAPID a quaternion q1..q4 = w x y z,
// normalised, its first non-zero component positive; KRL A, B, C and FANUC W, P, R ZYX Euler
// angles in degrees, R = Rz(A)·Ry(B)·Rx(C) (FANUC: W = C, P = B, R = A), each in (−180°, 180°],
// with B from the full third row of the matrix (exact near ±90°) and A read from R·Rx(C)⁻¹·Ry(B)⁻¹,
// so the three compose back to R also at gimbal lock. Anything else (URScript, an uploaded arm
// without a language, no cell): the quaternion.

/** The quaternion `[w, x, y, z]` normalised, its first non-zero component positive. */
export function canonicalQuaternion(p) {
  const n = Math.hypot(p.qw, p.qx, p.qy, p.qz) || 1;
  const q = [p.qw / n, p.qx / n, p.qy / n, p.qz / n];
  const first = q.find((c) => c !== 0) ?? 1;
  return first < 0 ? q.map((c) => -c) : q;
}

/** Row-major 3×3 rotation matrix of a quaternion `[w, x, y, z]` (unit). */
function matrixOf([w, x, y, z]) {
  return [
    [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
    [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
    [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
  ];
}

/** Quaternion product `a · b`, both `[w, x, y, z]`. */
function times([aw, ax, ay, az], [bw, bx, by, bz]) {
  return [
    aw * bw - ax * bx - ay * by - az * bz,
    aw * bx + ax * bw + ay * bz - az * by,
    aw * by - ax * bz + ay * bw + az * bx,
    aw * bz + ax * by - ay * bx + az * bw,
  ];
}

const degrees = (rad) => {
  const d = (rad * 180) / Math.PI;
  return d <= -180 ? d + 360 : d;
};

/**
 * ZYX Euler angles in degrees `[A, B, C]` with `R = Rz(A)·Ry(B)·Rx(C)`, each in (−180°, 180°]:
 * `euler_zyx_deg` of src/export/mod.rs, step for step.
 */
export function eulerZyxDeg(p) {
  const q = canonicalQuaternion(p);
  const m = matrixOf(q);
  const across = Math.hypot(m[2][1], m[2][2]);
  const b = Math.atan2(-m[2][0], across);
  const c = across < 1e-12 ? 0 : Math.atan2(m[2][1], m[2][2]);
  const rx = [Math.cos(-c / 2), Math.sin(-c / 2), 0, 0];
  const ry = [Math.cos(-b / 2), 0, Math.sin(-b / 2), 0];
  const r = matrixOf(times(times(q, rx), ry));
  const a = Math.atan2(r[1][0], r[0][0]);
  return [a, b, c].map(degrees);
}

/** The orientation notation of a program language: `rapid`, `krl`, `fanuc`, else quaternion. */
export function notation(language) {
  return ['rapid', 'krl', 'fanuc'].includes(language) ? language : 'quaternion';
}

/**
 * A pose in numbers as `language` writes it: `{ notation, position: [[name, mm] ×3],
 * orientation: [[name, value] …], unit }` (unit `''` for a quaternion, `'°'` for angles).
 */
export function inNumbers(p, language) {
  const how = notation(language);
  const position = [['x', p.x], ['y', p.y], ['z', p.z]];
  if (how === 'krl' || how === 'fanuc') {
    const [a, b, c] = eulerZyxDeg(p);
    const orientation = how === 'krl' ? [['A', a], ['B', b], ['C', c]] : [['W', c], ['P', b], ['R', a]];
    return { notation: how, position, orientation, unit: '°' };
  }
  const [w, x, y, z] = canonicalQuaternion(p);
  return { notation: how, position, orientation: [['q1', w], ['q2', x], ['q3', y], ['q4', z]], unit: '' };
}

/** `v` with `decimals` decimals, never `-0.0`. */
export function fixed(v, decimals) {
  const s = v.toFixed(decimals);
  return /^-[0.]+$/.test(s) ? s.slice(1) : s;
}

/** One line for a pose: `x 512.3 y -80.0 z 630.1 mm · A 180.00° B 0.00° C 180.00°`. */
export function describePose(p, language) {
  const n = inNumbers(p, language);
  const mm = n.position.map(([k, v]) => `${k} ${fixed(v, 1)}`).join(' ');
  const decimals = n.unit ? 2 : 4;
  const turn = n.orientation.map(([k, v]) => `${k} ${fixed(v, decimals)}${n.unit}`).join(' ');
  return `${mm} mm · ${turn}`;
}
