// The subset of three.js the mrnea report's 3D view uses, exposed as one global (MRNEA_THREE).
export {
  WebGLRenderer, Scene, PerspectiveCamera, Color, Group, Mesh, Line, LineSegments,
  BoxGeometry, CylinderGeometry, SphereGeometry, CapsuleGeometry, PlaneGeometry, BufferGeometry,
  BufferAttribute, Float32BufferAttribute, EdgesGeometry,
  MeshStandardMaterial, MeshBasicMaterial, LineBasicMaterial, LineDashedMaterial, ShadowMaterial,
  HemisphereLight, DirectionalLight, AmbientLight, GridHelper, AxesHelper,
  Vector3, Quaternion, Matrix4, Box3, Sphere, MathUtils,
  SRGBColorSpace, PCFSoftShadowMap, DoubleSide, REVISION,
} from 'three';
export { OrbitControls } from 'three/addons/controls/OrbitControls.js';
