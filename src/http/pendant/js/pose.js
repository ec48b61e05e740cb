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
