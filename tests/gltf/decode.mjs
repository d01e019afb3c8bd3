// Decodes an HDR image with three.js's own loaders, as a three.js page would.
//   node decode.mjs hdr|exr FILE half|float OUT.bin
// writes OUT.bin: float32 RGBA texels in the order the loader hands them to WebGL (row 0 is
// the texture's t = 0 row), preceded by a JSON line {width, height, flipY}.
import fs from 'node:fs';
import { DataUtils, FloatType, HalfFloatType } from 'three';
import { HDRLoader } from 'three/addons/loaders/HDRLoader.js';
import { EXRLoader } from 'three/addons/loaders/EXRLoader.js';

const [kind, file, precision, out] = process.argv.slice(2);
const loader = kind === 'hdr' ? new HDRLoader() : new EXRLoader();
loader.setDataType(precision === 'float' ? FloatType : HalfFloatType);
const bytes = fs.readFileSync(file);
const parsed = loader.parse(bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength));
let data = parsed.data;
if (parsed.type === HalfFloatType) data = Float32Array.from(data, (h) => DataUtils.fromHalfFloat(h));
const channels = data.length / (parsed.width * parsed.height);
const rgba = new Float32Array(parsed.width * parsed.height * 4);
for (let i = 0; i < parsed.width * parsed.height; i++) {
  for (let c = 0; c < 4; c++) rgba[i * 4 + c] = c < channels ? data[i * channels + c] : 1;
}
const head = JSON.stringify({ width: parsed.width, height: parsed.height, flipY: Boolean(parsed.flipY) }) + '\n';
fs.writeFileSync(out, Buffer.concat([Buffer.from(head), Buffer.from(rgba.buffer)]));
