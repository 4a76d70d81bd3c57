// MR-SNS WebXR hologram client. Served by the workstation (mrsns-cli serve
// --webxr-port, the GUI's Holograms panel) with three.js from Debian's
// libjs-three; talks to it over the WebSocket /ws on the same origin. The
// messages are described in modules/webxr/doc/webxr_client.md.
//
// Frames: the workstation sends hologram_T_model in millimetres, right-handed
// (Eq. 1 of paper 001). In an immersive session the hologram frame is the
// session's 'local' reference space (metres, right-handed, y up), which is
// what the HMD calibration solves for when this page is the headset's client;
// the root group's 0.001 scale is the only conversion.
import * as THREE from './three/build/three.module.js';
import { OrbitControls } from './three/examples/jsm/controls/OrbitControls.js';

const $ = (id) => document.getElementById(id);
const MAX_REPORT_CHARS = 3500;  // the workstation reads at most 4096 bytes per message
const PALETTE = [0xe8dcc0, 0xd84a4a, 0x4aa3d8, 0x6cc070, 0xd8a64a, 0xa070d0];

// --- scene ---------------------------------------------------------------------------------------------------------
const canvas = $('view');
let renderer = null;
try {
  renderer = new THREE.WebGLRenderer({ canvas, antialias: true, alpha: true });
} catch (e) {
  showPairingError('This browser cannot draw WebGL: ' + e.message);
}
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x101418);
const camera = new THREE.PerspectiveCamera(50, 1, 0.01, 20);
camera.position.set(0, 0, 0.6);
scene.add(camera);
scene.add(new THREE.HemisphereLight(0xffffff, 0x404040, 0.9));
const headLight = new THREE.DirectionalLight(0xffffff, 0.6);
camera.add(headLight);
const hologram = new THREE.Group();  // the hologram frame; millimetres inside
hologram.scale.setScalar(0.001);
scene.add(hologram);
const controls = renderer ? new OrbitControls(camera, canvas) : null;

const models = new Map();  // name -> { group, mesh, material, ok, seq, t, shownSeq, hasPose, baseColor }
let pendingTransforms = new Map();  // transforms that came before their mesh
let fitted = false;

function modelColor(name, index) {
  const n = name.toLowerCase();
  if (/screw|trajectory|path/.test(n)) return 0x4ad870;
  if (/vessel|arter|vein|carotid|vertebral/.test(n)) return 0xd84a4a;
  if (/cube/.test(n)) return 0x40c8e0;
  if (/bone|vertebra|^c\d|^t\d|^l\d|spine/.test(n)) return 0xe8dcc0;
  return PALETTE[index % PALETTE.length];
}

function setMesh(name, geometry, hasColors) {
  removeModel(name);
  const material = new THREE.MeshStandardMaterial({
    color: hasColors ? 0xffffff : modelColor(name, models.size), vertexColors: hasColors ? THREE.VertexColors : THREE.NoColors,
    side: THREE.DoubleSide, roughness: 0.6, metalness: 0.0, transparent: true, opacity: 0.9 });
  const mesh = new THREE.Mesh(geometry, material);
  const group = new THREE.Group();
  group.matrixAutoUpdate = false;
  group.visible = false;  // until its first pose: a model is never drawn where it is not known to be
  group.add(mesh);
  hologram.add(group);
  const model = { group, mesh, material, ok: true, seq: 0, t: 0, shownSeq: 0, hasPose: false };
  models.set(name, model);
  if (pendingTransforms.has(name)) {
    applyTransform(pendingTransforms.get(name));
    pendingTransforms.delete(name);
  }
  updateHud();
}

function removeModel(name) {
  const model = models.get(name);
  if (!model) return;
  hologram.remove(model.group);
  model.mesh.geometry.dispose();
  model.material.dispose();
  models.delete(name);
}

function clearScene() {
  for (const name of [...models.keys()]) removeModel(name);
  pendingTransforms = new Map();
  fitted = false;
}

function applyTransform(message) {
  const model = models.get(message.name);
  if (!model) {
    pendingTransforms.set(message.name, message);
    return;
  }
  const m = message.m;  // row-major
  model.group.matrix.set(m[0], m[1], m[2], m[3], m[4], m[5], m[6], m[7], m[8], m[9], m[10], m[11], m[12], m[13],
    m[14], m[15]);
  model.group.matrixWorldNeedsUpdate = true;
  model.seq = message.seq;
  model.t = message.t;
  model.hasPose = true;
  showModelState(model);
}

function showModelState(model) {
  model.group.visible = model.hasPose;
  // Lost tracking: a faint wireframe where it was last seen, and the banner says so.
  model.material.wireframe = !model.ok;
  model.material.opacity = model.ok ? 0.9 : 0.25;
}

function fitView() {
  const box = new THREE.Box3();
  hologram.updateMatrixWorld(true);
  for (const model of models.values()) if (model.group.visible) box.expandByObject(model.group);
  if (box.isEmpty() || !controls) return false;
  const center = box.getCenter(new THREE.Vector3());
  const size = box.getSize(new THREE.Vector3()).length();
  controls.target.copy(center);
  camera.position.copy(center).add(new THREE.Vector3(0, -0.2 * size, 1.6 * size));
  camera.near = size / 100;
  camera.far = size * 20;
  camera.updateProjectionMatrix();
  controls.update();
  return true;
}

// --- messages from the workstation ---------------------------------------------------------------------------------
function onBinary(buffer) {
  const view = new DataView(buffer);
  const headerLength = view.getUint32(0, true);
  const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, headerLength)));
  let at = Math.ceil((4 + headerLength) / 4) * 4;
  const floats = (n) => { const a = new Float32Array(buffer.slice(at, at + 4 * n)); at += 4 * n; return a; };
  if (header.type === 'mesh') {
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(floats(3 * header.vertices), 3));
    const index = new Uint32Array(buffer.slice(at, at + 12 * header.faces));
    at += 12 * header.faces;
    geometry.setIndex(new THREE.BufferAttribute(index, 1));
    if (header.colors) geometry.setAttribute('color', new THREE.BufferAttribute(floats(3 * header.vertices), 3));
    geometry.computeVertexNormals();
    setMesh(header.name, geometry, header.colors);
  } else if (header.type === 'vertices') {
    const model = models.get(header.name);
    if (!model) return;
    const position = model.mesh.geometry.getAttribute('position');
    if (position.count !== header.count) return;
    position.array.set(floats(3 * header.count));
    position.needsUpdate = true;
    model.mesh.geometry.computeVertexNormals();
    model.mesh.geometry.computeBoundingSphere();
  }
}

function onText(message) {
  switch (message.type) {
    case 'paired':
      sessionStorage.setItem('mrsns-pairing-code', code);
      $('pairing').hidden = true;
      $('hud').hidden = false;
      break;
    case 'refused':
      refused = true;
      sessionStorage.removeItem('mrsns-pairing-code');
      showPairingError('The workstation refused this page: ' + message.reason);
      break;
    case 'hello':
      clearScene();
      break;
    case 'stream':
      streamConnected = message.connected;
      break;
    case 'transform':
      applyTransform(message);
      return;  // the hot path: the heads-up display has not changed
    case 'status': {
      const model = models.get(message.name);
      lostText.set(message.name, message.ok ? null : (message.text || 'tracking lost'));
      if (model) { model.ok = message.ok; showModelState(model); }
      break;
    }
    case 'prompt':
      setPrompt(message.text);
      break;
    case 'latency':
      latencyText = `latency p50 ${message.p50_ms.toFixed(0)} ms, p99 ${message.p99_ms.toFixed(0)} ms`;
      break;
  }
  updateHud();
}

// --- heads-up display ----------------------------------------------------------------------------------------------
let streamConnected = false;
let socketOpen = false;
let latencyText = 'latency -';
const lostText = new Map();
let promptText = '';

function pill(element, text, good) {
  element.textContent = text;
  element.className = 'pill ' + (good ? 'ok' : 'bad');
}

function updateHud() {
  pill($('connection'), !socketOpen ? 'reconnecting' : streamConnected ? 'connected' : 'workstation stream lost',
    socketOpen && streamConnected);
  $('latency').textContent = latencyText;
  $('models').textContent = `${models.size} model${models.size === 1 ? '' : 's'}`;
  const lost = [...lostText.entries()].filter(([, text]) => text).map(([name]) => name);
  $('lost').hidden = lost.length === 0;
  $('lost').textContent = lost.length ? 'Tracking lost: ' + lost.join(', ') : '';
  drawPromptSprite();
}

function setPrompt(text) {
  promptText = text;
  $('prompt').hidden = !text;
  $('prompt').textContent = text;
}

// In a headset the HTML overlay is not drawn: the prompt and the alerts are a sprite 1.5 m ahead.
const promptCanvas = document.createElement('canvas');
promptCanvas.width = 1024;
promptCanvas.height = 256;
const promptTexture = new THREE.CanvasTexture(promptCanvas);
const promptSprite = new THREE.Sprite(new THREE.SpriteMaterial({ map: promptTexture, depthTest: false }));
promptSprite.scale.set(0.8, 0.2, 1);
promptSprite.position.set(0, -0.25, -1.5);
promptSprite.visible = false;
camera.add(promptSprite);

let promptSpriteKey = null;

function drawPromptSprite() {
  if (!promptSprite.visible) return;
  const key = [$('lost').textContent, socketOpen, streamConnected, promptText].join('\n');
  if (key === promptSpriteKey) return;  // redrawn (and uploaded) only when its text changes
  promptSpriteKey = key;
  const g = promptCanvas.getContext('2d');
  g.clearRect(0, 0, promptCanvas.width, promptCanvas.height);
  const lines = [];
  if (!$('lost').hidden) lines.push(['#ff8a80', $('lost').textContent]);
  if (!socketOpen || !streamConnected) lines.push(['#ff8a80', 'Workstation not connected']);
  if (promptText) lines.push(['#ffffff', promptText]);
  if (!lines.length) { promptSprite.material.opacity = 0; promptTexture.needsUpdate = true; return; }
  promptSprite.material.opacity = 1;
  g.fillStyle = 'rgba(0,0,0,0.7)';
  g.fillRect(0, 0, promptCanvas.width, promptCanvas.height);
  g.font = '40px sans-serif';
  g.textAlign = 'center';
  lines.slice(0, 4).forEach(([color, text], i) => { g.fillStyle = color; g.fillText(text, 512, 60 + 55 * i, 1000); });
  promptTexture.needsUpdate = true;
}

// --- the connection --------------------------------------------------------------------------------------------------
let socket = null;
let code = '';
let refused = false;
let retryDelay = 500;

function showPairingError(text) {
  $('pairing').hidden = false;
  $('hud').hidden = true;
  $('pairing-error').hidden = false;
  $('pairing-error').textContent = text;
}

function connect() {
  refused = false;
  const ws = new WebSocket(`wss://${location.host}/ws`);
  socket = ws;
  ws.binaryType = 'arraybuffer';
  ws.onopen = () => {
    socketOpen = true;
    retryDelay = 500;
    ws.send(JSON.stringify({ type: 'pair', code }));
    updateHud();
  };
  ws.onmessage = (event) => {
    if (typeof event.data === 'string') onText(JSON.parse(event.data));
    else onBinary(event.data);
  };
  ws.onclose = () => {
    if (ws !== socket) return;  // replaced by a new pairing from the form
    socketOpen = false;
    updateHud();
    if (refused) return;
    // Dropped (workstation restarted, network): try again, the scene comes back whole on pairing.
    setTimeout(connect, retryDelay);
    retryDelay = Math.min(5000, retryDelay * 2);
  };
}

function send(message) {
  if (socket && socket.readyState === WebSocket.OPEN) socket.send(JSON.stringify(message));
}

function confirm(how) {
  send({ type: 'confirm', text: how });
  const button = $('confirm');
  button.textContent = 'Confirmed';
  setTimeout(() => { button.textContent = 'Confirm'; }, 800);
}

// After a frame is drawn, tell the workstation which poses it shows (its latency figure), in messages it accepts.
function reportShown() {
  let batch = [];
  let chars = 0;
  for (const [name, model] of models) {
    if (!model.hasPose || model.shownSeq === model.seq) continue;
    model.shownSeq = model.seq;
    const e = model.group.matrix.elements;  // column-major
    const m = [e[0], e[4], e[8], e[12], e[1], e[5], e[9], e[13], e[2], e[6], e[10], e[14], e[3], e[7], e[11], e[15]];
    const entry = { name, t: model.t, m };
    const size = JSON.stringify(entry).length + 1;
    if (chars + size > MAX_REPORT_CHARS && batch.length) {
      send({ type: 'shown', models: batch });
      batch = [];
      chars = 0;
    }
    batch.push(entry);
    chars += size;
  }
  if (batch.length) send({ type: 'shown', models: batch });
}

// --- input: button, select gesture, voice ---------------------------------------------------------------------------
$('confirm').addEventListener('click', () => confirm('button'));
$('fit').addEventListener('click', () => { fitted = fitView(); });
$('pairing').addEventListener('submit', (event) => {
  event.preventDefault();
  code = $('code').value.trim();
  $('pairing-error').hidden = true;
  const previous = socket;
  connect();
  if (previous) previous.close();
});

const Recognition = window.SpeechRecognition || window.webkitSpeechRecognition;
if (Recognition) {
  let recognition = null;
  $('voice').hidden = false;
  $('voice').addEventListener('click', () => {
    if (recognition) { recognition.onend = null; recognition.stop(); recognition = null; $('voice').textContent = 'Voice: off'; return; }
    recognition = new Recognition();
    recognition.continuous = true;
    recognition.onresult = (event) => {
      const heard = event.results[event.results.length - 1][0].transcript.toLowerCase();
      if (/\bconfirm/.test(heard)) confirm('voice');
    };
    recognition.onend = () => { if (recognition) recognition.start(); };
    recognition.start();
    $('voice').textContent = 'Voice: say "confirm"';
  });
}

async function setUpXr() {
  if (!renderer || !navigator.xr) return;
  let mode = null;
  if (await navigator.xr.isSessionSupported('immersive-ar').catch(() => false)) mode = 'immersive-ar';
  else if (await navigator.xr.isSessionSupported('immersive-vr').catch(() => false)) mode = 'immersive-vr';
  if (!mode) return;
  const button = $('enter-xr');
  button.hidden = false;
  button.textContent = mode === 'immersive-ar' ? 'Enter AR' : 'Enter XR';
  button.addEventListener('click', async () => {
    const session = await navigator.xr.requestSession(mode, { optionalFeatures: ['dom-overlay'],
      domOverlay: { root: $('overlay') } });
    scene.background = null;  // see-through
    renderer.vr.enabled = true;
    renderer.vr.setReferenceSpaceType('local');
    renderer.vr.setSession(session);
    promptSprite.visible = true;
    promptSpriteKey = null;
    drawPromptSprite();
    session.addEventListener('select', () => confirm('select gesture'));
    session.addEventListener('end', () => {
      renderer.vr.enabled = false;
      scene.background = new THREE.Color(0x101418);
      promptSprite.visible = false;
      resize();
    });
  });
}

function resize() {
  if (!renderer) return;
  const width = window.innerWidth;
  const height = window.innerHeight;
  renderer.setSize(width, height, false);
  camera.aspect = width / Math.max(1, height);
  camera.updateProjectionMatrix();
}
window.addEventListener('resize', resize);
resize();

if (renderer) {
  renderer.setAnimationLoop(() => {
    if (!fitted && models.size) fitted = fitView();
    renderer.render(scene, camera);
    reportShown();
  });
}
setUpXr();

// Inspection hooks for tests and for a curious engineer's console.
window.mrsns = { models, scene, hologram, fitView };

code = new URLSearchParams(location.search).get('code') || sessionStorage.getItem('mrsns-pairing-code') || '';
if (code) { $('code').value = code; connect(); }
updateHud();
