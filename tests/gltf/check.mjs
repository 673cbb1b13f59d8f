// node check.mjs FILE.glb...: one JSON line per file with what the Khronos glTF
// validator reports and what three.js' GLTFLoader builds from it (the reader of
// three.js users). Run from the folder where `npm ci` installed package.json.
import fs from 'fs';
import * as THREE from 'three';
import validator from 'gltf-validator';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';

function load(ab) {
  return new Promise((resolve, reject) => new GLTFLoader().parse(ab, '', resolve, reject));
}

for (const file of process.argv.slice(2)) {
  const buf = fs.readFileSync(file);
  const v = await validator.validateBytes(new Uint8Array(buf), { maxIssues: 20 });
  const out = { file, errors: v.issues.numErrors, warnings: v.issues.numWarnings, infos: v.issues.numInfos,
                messages: v.issues.messages.map((m) => `${m.code} ${m.pointer || ''}: ${m.message}`) };
  try {
    const gltf = await load(buf.buffer.slice(buf.byteOffset, buf.byteOffset + buf.byteLength));
    const t = { primitives: 0, triangles: 0, points: 0, vertexColoured: 0, positions: [], colours: [], up: null };
    gltf.scene.updateMatrixWorld(true);
    gltf.scene.traverse((o) => {
      if (!o.isMesh && !o.isPoints) return;
      const g = o.geometry;
      t.primitives++;
      if (o.isMesh) t.triangles += (g.index ? g.index.count : g.attributes.position.count) / 3;
      else t.points += g.attributes.position.count;
      if (g.attributes.color && o.material.vertexColors) t.vertexColoured++;
      t.positions.push(g.attributes.position.count);
      t.colours.push(o.material.color.getHexString(THREE.SRGBColorSpace));
    });
    const box = new THREE.Box3().setFromObject(gltf.scene);
    t.box = [box.min.toArray(), box.max.toArray()];
    out.three = t;
  } catch (e) {
    out.three_error = String(e && e.message || e);
  }
  console.log(JSON.stringify(out));
}
