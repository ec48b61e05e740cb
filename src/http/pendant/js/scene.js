// The 3D view: the cell's arm drawn from the link frames the server gives (no kinematics
// here), the taught path, the suggested next waypoint as a ghost of the arm at the joint
// solution the service chose with its TCP frame, the look-ahead path, and the camera views.
// Renders on demand (a change, an animation), not continuously.

import {
  AmbientLight, AxesHelper, BufferGeometry, Color, CylinderGeometry, DirectionalLight,
  GridHelper, Group, Line, LineBasicMaterial, LineDashedMaterial, Mesh, MeshStandardMaterial,
  PerspectiveCamera, Scene, SphereGeometry, Vector3, WebGLRenderer, Box3, OrbitControls,
} from '../vendor/three/three.min.js';
import { positionOf, quaternionOf } from './pose.js';

const UP = new Vector3(0, 1, 0);
const CYLINDER = new CylinderGeometry(1, 1, 1, 16);
const SPHERE = new SphereGeometry(1, 16, 12);

/** Colour of a suggestion by its probability of being useful. */
export function colourOf(p) {
  if (p == null) return 0x6f8fb0;
  if (p >= 0.8) return 0x2ecc71;
  if (p >= 0.5) return 0xf0b429;
  return 0x6f8fb0;
}

/** An arm figure: a cylinder per segment between frame origins, a sphere per joint. */
class ArmFigure {
  constructor(material, radius) {
    this.group = new Group();
    this.material = material;
    this.radius = radius;
    this.segments = [];
    this.joints = [];
    this.axes = new AxesHelper(90);
    this.group.add(this.axes);
  }

  /** Draws the arm of `frames` (the API's ArmFrames). */
  update(frames) {
    const points = [
      ...frames.links.map((l) => positionOf(l.pose)),
      positionOf(frames.flange),
      positionOf(frames.tcp),
    ].filter((p, i, all) => i === 0 || p.distanceTo(all[i - 1]) > 1e-6);
    while (this.segments.length < points.length - 1) {
      const m = new Mesh(CYLINDER, this.material);
      this.segments.push(m);
      this.group.add(m);
    }
    while (this.joints.length < points.length) {
      const s = new Mesh(SPHERE, this.material);
      this.joints.push(s);
      this.group.add(s);
    }
    this.segments.forEach((m, i) => {
      m.visible = i < points.length - 1;
      if (!m.visible) return;
      const a = points[i];
      const b = points[i + 1];
      const d = b.clone().sub(a);
      const tool = i === points.length - 2;
      const r = tool ? this.radius * 0.35 : this.radius;
      m.position.copy(a).add(b).multiplyScalar(0.5);
      m.quaternion.setFromUnitVectors(UP, d.clone().normalize());
      m.scale.set(r, d.length(), r);
    });
    this.joints.forEach((s, i) => {
      s.visible = i < points.length;
      if (!s.visible) return;
      s.position.copy(points[i]);
      s.scale.setScalar(this.radius * (i === points.length - 1 ? 0.5 : 1.25));
    });
    this.axes.position.copy(positionOf(frames.tcp));
    this.axes.quaternion.copy(quaternionOf(frames.tcp));
  }
}

export class View {
  constructor(container) {
    this.container = container;
    this.scene = new Scene();
    this.scene.background = new Color(0x1a1f25);
    this.camera = new PerspectiveCamera(40, 1, 5, 50000);
    this.camera.up.set(0, 0, 1);
    this.renderer = new WebGLRenderer({ antialias: true });
    this.renderer.setPixelRatio(window.devicePixelRatio || 1);
    container.appendChild(this.renderer.domElement);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.addEventListener('change', () => this.render());

    this.scene.add(new AmbientLight(0xffffff, 0.7));
    const sun = new DirectionalLight(0xffffff, 1.6);
    sun.position.set(1500, -1000, 3000);
    this.scene.add(sun);
    const grid = new GridHelper(4000, 40, 0x44515e, 0x2c343d);
    grid.rotation.x = Math.PI / 2; // the floor is z = 0
    this.scene.add(grid);
    this.scene.add(new AxesHelper(200));

    this.arm = new ArmFigure(new MeshStandardMaterial({ color: 0xc9d1d9, metalness: 0.3, roughness: 0.5 }), 28);
    this.scene.add(this.arm.group);
    this.ghostMaterial = new MeshStandardMaterial({ color: 0x2ecc71, transparent: true, opacity: 0.45, depthWrite: false });
    this.ghost = new ArmFigure(this.ghostMaterial, 28);
    this.ghost.group.visible = false;
    this.scene.add(this.ghost.group);
    this.target = new Mesh(SPHERE, new MeshStandardMaterial({ color: 0xff4d4d }));
    this.target.scale.setScalar(22);
    this.target.visible = false;
    this.targetAxes = new AxesHelper(110);
    this.targetAxes.visible = false;
    this.scene.add(this.target, this.targetAxes);

    this.paths = new Group();
    this.scene.add(this.paths);
    this.ahead = null;
    this.markers = 0;

    this.setView('oblique', new Vector3(400, 0, 300), 1800);
    new ResizeObserver(() => this.resize()).observe(container);
    this.resize();
  }

  resize() {
    const w = Math.max(1, this.container.clientWidth);
    const h = Math.max(1, this.container.clientHeight);
    this.renderer.setSize(w, h);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.render();
  }

  render() {
    this.renderer.render(this.scene, this.camera);
  }

  drawArm(frames) {
    this.arm.update(frames);
    this.container.dataset.joints = JSON.stringify(frames.joints);
    this.render();
  }

  /**
   * The suggestion: `frames` (the arm at the chosen solution, or null when there is none),
   * the suggested TCP `pose`, its probability `p`, and whether the arm reaches it.
   */
  showGhost(frames, pose, p, reachable) {
    this.ghost.group.visible = Boolean(frames);
    if (frames) {
      this.ghostMaterial.color.setHex(reachable ? colourOf(p) : 0xff4d4d);
      this.ghost.update(frames);
    }
    this.targetAxes.visible = true;
    this.targetAxes.position.copy(positionOf(pose));
    this.targetAxes.quaternion.copy(quaternionOf(pose));
    this.target.visible = !reachable;
    this.target.position.copy(positionOf(pose));
    this.container.dataset.ghost = reachable ? 'shown' : 'unreachable';
    this.render();
  }

  hideGhost() {
    this.ghost.group.visible = false;
    this.target.visible = false;
    this.targetAxes.visible = false;
    this.container.dataset.ghost = 'none';
    this.render();
  }

  /** The routine being shown (bright, unreachable waypoints red) and the program's others (faint). */
  drawPaths(current, others) {
    this.paths.clear();
    for (const waypoints of others) this.addPath(waypoints, 0x8091a3, false);
    this.markers = this.addPath(current, 0x9fd3ff, true);
    this.container.dataset.waypoints = String(this.markers);
    this.render();
  }

  addPath(waypoints, colour, markers) {
    const points = waypoints.map((w) => positionOf(w.pose));
    if (points.length > 1) {
      const line = new Line(new BufferGeometry().setFromPoints(points), new LineBasicMaterial({ color: colour }));
      this.paths.add(line);
    }
    if (!markers) return 0;
    const ok = new MeshStandardMaterial({ color: colour });
    const bad = new MeshStandardMaterial({ color: 0xff4d4d });
    waypoints.forEach((w) => {
      const s = new Mesh(SPHERE, w.reachable === false ? bad : ok);
      s.scale.setScalar(9);
      s.position.copy(positionOf(w.pose));
      this.paths.add(s);
    });
    return waypoints.length;
  }

  /**
   * The next suggestions, dotted from `from` (the last waypoint's pose), each a ghost marker:
   * `ahead` is `[{ pose, reachable }]`; a slot the arm cannot reach is red.
   */
  drawAhead(from, ahead) {
    if (this.ahead) this.scene.remove(this.ahead);
    this.ahead = null;
    if (from && ahead.length) {
      const group = new Group();
      const points = [from, ...ahead.map((a) => a.pose)].map(positionOf);
      const line = new Line(
        new BufferGeometry().setFromPoints(points),
        new LineDashedMaterial({ color: 0xf0e68c, dashSize: 12, gapSize: 8 }),
      );
      line.computeLineDistances();
      group.add(line);
      const ghost = new MeshStandardMaterial({ color: 0xf0e68c, transparent: true, opacity: 0.55 });
      const bad = new MeshStandardMaterial({ color: 0xff4d4d });
      for (const a of ahead) {
        const s = new Mesh(SPHERE, a.reachable ? ghost : bad);
        s.scale.setScalar(a.reachable ? 7 : 11);
        s.position.copy(positionOf(a.pose));
        group.add(s);
      }
      this.ahead = group;
      this.scene.add(group);
    }
    this.render();
  }

  /** `top`, `front` (looking along −x at the arm), `side` (along +y), `oblique` (the start). */
  setView(which, centre = this.controls.target.clone(), distance = 2600) {
    const offsets = {
      top: new Vector3(0, -1e-3, 1),
      front: new Vector3(1, 0, 0.35),
      side: new Vector3(0, -1, 0.35),
      oblique: new Vector3(1, -0.8, 0.55),
    };
    const o = offsets[which].clone().normalize().multiplyScalar(distance);
    this.controls.target.copy(centre);
    this.camera.position.copy(centre).add(o);
    this.camera.lookAt(centre);
    this.controls.update();
    this.render();
  }

  /** Frames the arm and the paths. */
  fit() {
    const box = new Box3().setFromObject(this.arm.group).union(new Box3().setFromObject(this.paths));
    if (box.isEmpty()) return;
    const centre = box.getCenter(new Vector3());
    const size = box.getSize(new Vector3()).length();
    const direction = this.camera.position.clone().sub(this.controls.target).normalize();
    this.controls.target.copy(centre);
    this.camera.position.copy(centre).add(direction.multiplyScalar(Math.max(800, size * 1.6)));
    this.controls.update();
    this.render();
  }

  /** Renders each step of an animation (a promise per frame of the browser). */
  async animate(steps, onStep, ms = 400) {
    const start = performance.now();
    for (;;) {
      const t = Math.min(1, (performance.now() - start) / ms);
      onStep(steps[Math.min(steps.length - 1, Math.floor(t * (steps.length - 1) + 1e-9))]);
      if (t >= 1) return;
      await new Promise((resolve) => requestAnimationFrame(resolve));
    }
  }
}
