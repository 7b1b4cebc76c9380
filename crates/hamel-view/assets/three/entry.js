// hamel's three.js bundle: the core and the orbit controls, as one classic script that sets
// `window.THREE` (a page opened from disk cannot import modules by name).
import * as THREE_NS from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
window.THREE = Object.assign({}, THREE_NS, { OrbitControls });
