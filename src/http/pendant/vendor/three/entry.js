// What the pendant imports from three.js; scripts/refresh-three.sh bundles these into
// three.min.js (not served: the page imports three.min.js).
export {
  AmbientLight, AxesHelper, Box3, BufferGeometry, Color, CylinderGeometry, DirectionalLight,
  GridHelper, Group, Line, LineBasicMaterial, LineDashedMaterial, Mesh, MeshStandardMaterial,
  PerspectiveCamera, Quaternion, Scene, SphereGeometry, Vector3, WebGLRenderer,
} from 'three';
export { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
