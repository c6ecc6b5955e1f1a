// End-to-end test of meshsmoothd through its gRPC API, from a Node.js client written with Node's
// built-in modules alone (no npm package: CI installs Debian packages only, and Debian has no
// grpc-js). The few pieces a gRPC client needs are written out below: protobuf's wire format
// for the messages used, with their field numbers checked against smoothing.proto first, and
// gRPC's framing over node:http2.
//
// Run (ctest does this):
//   node tests/node/e2e_client_test.mjs --server build/server/meshsmoothd \
//       --cli build/client/meshsmooth --proto proto/meshsmooth/v1/smoothing.proto
//
// Needs node (18 or later), Debian's draco (draco_decoder) and the meshsmooth CLI, which writes
// the upload: a noisy icosphere with a per-vertex strength in a GENERIC Draco attribute named by
// its metadata (Debian's draco_encoder writes none; see makeStrengthUpload). Prints one
// "ok: ..." / "FAIL: ..." line per check and closes with "N passed, M failed"; exits 1 when
// anything failed.
import { execFileSync, spawn } from 'node:child_process';
import fs from 'node:fs';
import http2 from 'node:http2';
import os from 'node:os';
import path from 'node:path';

const EXPECTED_FLOWS = ['bilaplacian', 'bilateral_normal', 'guided_normal', 'laplacian', 'mcf', 'mcf_tangential',
  'median', 'taubin'];
const CHUNK_BYTES = 4 * 1024;  // well below the contract's 1 MiB: the upload goes in several chunks
const DEADLINE_SECONDS = 60;
const STRENGTH = 'strength';  // the upload's strength attribute
const OVER = 'over';          // an attribute with one value outside [0, 1] (1.5 at vertex 7)
const GRPC_INVALID_ARGUMENT = 3;

// ---------------------------------------------------------------------------------------------
// Checks

let passed = 0;
let failed = 0;

// Runs fn as the check NAME and prints "ok: NAME" or "FAIL: NAME: WHY"; returns fn's value, or
// undefined when it threw.
async function check(name, fn) {
  try {
    const value = await fn();
    passed++;
    console.log(`ok: ${name}`);
    return value;
  } catch (e) {
    failed++;
    console.log(`FAIL: ${name}: ${e instanceof CheckFailed ? e.message : e.stack}`);
    return undefined;
  }
}

class CheckFailed extends Error {}

function require(condition, message) {
  if (!condition) throw new CheckFailed(message);
}

// ---------------------------------------------------------------------------------------------
// Protobuf's wire format, for the fields used here

// The field numbers this client uses, by message; checkFieldNumbers reads them in the .proto.
const FIELDS = {
  SmoothRequest: { spec: 1, mesh_chunk: 2 },
  JobSpec: { flow: 1, iterations: 2, strength_attribute: 16 },
  SmoothResponse: { accepted: 1, progress: 2, result_chunk: 3, summary: 4 },
  Summary: { parameters: 7, result_bytes: 8 },
  EffectiveParameters: { flow: 1, iterations_run: 3 },
  ListFlowsResponse: { flows: 1 },
  FlowInfo: { name: 1 },
};
const VARINT = 0;
const FIXED64 = 1;
const LENGTH_DELIMITED = 2;
const FIXED32 = 5;

function varint(n) {
  const bytes = [];
  while (n >= 0x80) {
    bytes.push((n % 0x80) | 0x80);
    n = Math.floor(n / 0x80);
  }
  bytes.push(n);
  return Buffer.from(bytes);
}

// One field: its key (number << 3 | wire type), then a varint or a length and the bytes.
function field(number, value) {
  if (typeof value === 'number') return Buffer.concat([varint(number * 8 + VARINT), varint(value)]);
  const bytes = typeof value === 'string' ? Buffer.from(value, 'utf8') : value;
  return Buffer.concat([varint(number * 8 + LENGTH_DELIMITED), varint(bytes.length), bytes]);
}

// A message from {name: value} of `type` (FIELDS); proto3 leaves out fields at their default.
function encode(type, values) {
  const parts = [];
  for (const [name, value] of Object.entries(values)) {
    require(FIELDS[type][name] !== undefined, `no field ${type}.${name} in FIELDS`);
    if (value === 0 || value === '' || value === undefined) continue;
    parts.push(field(FIELDS[type][name], value));
  }
  return Buffer.concat(parts);
}

// A message of `type` as {name: [values]} for the fields FIELDS names (varints as numbers,
// the rest as Buffers); other fields are skipped.
function decode(type, buf) {
  const names = Object.fromEntries(Object.entries(FIELDS[type]).map(([name, n]) => [n, name]));
  const out = {};
  let at = 0;
  const readVarint = () => {
    let n = 0;
    for (let scale = 1; ; scale *= 0x80) {
      require(at < buf.length, `${type}: truncated varint`);
      const b = buf[at++];
      n += (b & 0x7f) * scale;
      if (b < 0x80) return n;
    }
  };
  while (at < buf.length) {
    const key = readVarint();
    const wire = key % 8;
    const number = Math.floor(key / 8);
    let value;
    if (wire === VARINT) {
      value = readVarint();
    } else if (wire === LENGTH_DELIMITED || wire === FIXED64 || wire === FIXED32) {
      const length = wire === LENGTH_DELIMITED ? readVarint() : wire === FIXED64 ? 8 : 4;
      require(at + length <= buf.length, `${type}: field ${number} runs past the end`);
      value = buf.subarray(at, at + length);
      at += length;
    } else {
      throw new CheckFailed(`${type}: wire type ${wire} of field ${number}`);
    }
    if (names[number] !== undefined) (out[names[number]] ??= []).push(value);
  }
  return out;
}

// Every number of FIELDS as smoothing.proto declares it.
function checkFieldNumbers(protoText) {
  for (const [type, fields] of Object.entries(FIELDS)) {
    const start = protoText.search(new RegExp(`\\bmessage ${type} \\{`));
    require(start >= 0, `no message ${type} in the .proto`);
    let depth = 0;
    let end = protoText.indexOf('{', start);
    do {
      if (protoText[end] === '{') depth++;
      if (protoText[end] === '}') depth--;
      end++;
    } while (depth > 0 && end < protoText.length);
    const body = protoText.slice(start, end);
    for (const [name, number] of Object.entries(fields)) {
      const m = body.match(new RegExp(`\\s${name}\\s*=\\s*(\\d+)\\s*;`));
      require(m && Number(m[1]) === number, `${type}.${name} is ${m ? m[1] : 'missing'} in the .proto, ${number} here`);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// gRPC over HTTP/2: each message as a 5-byte prefix (0 = not compressed, then the length,
// big-endian) and its bytes; the status in the trailers (or, when nothing else comes, in the
// response headers: "Trailers-Only").

function frame(message) {
  const prefix = Buffer.alloc(5);
  prefix.writeUInt32BE(message.length, 1);
  return Buffer.concat([prefix, message]);
}

function unframe(data) {
  const messages = [];
  for (let at = 0; at < data.length;) {
    require(at + 5 <= data.length, 'a truncated gRPC message prefix');
    require(data[at] === 0, `a compressed gRPC message (flag ${data[at]}) this client did not ask for`);
    const length = data.readUInt32BE(at + 1);
    require(at + 5 + length <= data.length, 'a truncated gRPC message');
    messages.push(data.subarray(at + 5, at + 5 + length));
    at += 5 + length;
  }
  return messages;
}

// Calls /meshsmooth.v1.MeshSmoother/METHOD with `requests` (encoded messages), then
// half-closes. Resolves with {status, message, replies} once the stream has closed.
function call(session, method, requests) {
  return new Promise((resolve, reject) => {
    const stream = session.request({
      ':method': 'POST',
      ':path': `/meshsmooth.v1.MeshSmoother/${method}`,
      'content-type': 'application/grpc',
      te: 'trailers',
      'grpc-timeout': `${DEADLINE_SECONDS}S`,
    });
    let headers = {};
    let trailers = {};
    const chunks = [];
    stream.on('response', (h) => { headers = h; });
    stream.on('trailers', (t) => { trailers = t; });
    stream.on('data', (chunk) => chunks.push(chunk));
    stream.on('error', () => {});  // a reset without a status is reported on 'close'
    stream.on('close', () => {
      const status = trailers['grpc-status'] ?? headers['grpc-status'];
      if (status === undefined) {
        reject(new CheckFailed(`${method}: no grpc-status (HTTP ${headers[':status']}, reset code ${stream.rstCode})`));
        return;
      }
      let message = trailers['grpc-message'] ?? headers['grpc-message'] ?? '';
      try {
        message = decodeURIComponent(message);  // gRPC percent-encodes the message
      } catch {
        // kept as it came
      }
      try {
        require(headers[':status'] === 200, `${method}: HTTP status ${headers[':status']}`);
        require(String(headers['content-type']).startsWith('application/grpc'),
          `${method}: content-type ${headers['content-type']}`);
        resolve({ status: Number(status), message, replies: unframe(Buffer.concat(chunks)) });
      } catch (e) {
        reject(e);
      }
    });
    for (const request of requests) stream.write(frame(request));
    stream.end();
  });
}

function smoothRequests(spec, upload) {
  const requests = [encode('SmoothRequest', { spec: encode('JobSpec', spec) })];
  for (let at = 0; at < upload.length; at += CHUNK_BYTES) {
    requests.push(encode('SmoothRequest', { mesh_chunk: upload.subarray(at, at + CHUNK_BYTES) }));
  }
  return requests;
}

// ---------------------------------------------------------------------------------------------
// The upload and Draco's own decoder

// A unit icosphere subdivided `levels` times: {verts: [[x, y, z]], faces: [[a, b, c]]}, outward.
function icosphere(levels) {
  const t = (1 + Math.sqrt(5)) / 2;
  const unit = (p) => { const n = Math.hypot(...p); return p.map((c) => c / n); };
  const verts = [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
    [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]].map(unit);
  let faces = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
    [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10],
    [8, 6, 7], [9, 8, 1]];
  for (let level = 0; level < levels; level++) {
    const middle = new Map();
    const mid = (a, b) => {
      const key = `${Math.min(a, b)},${Math.max(a, b)}`;
      if (!middle.has(key)) {
        verts.push(unit(verts[a].map((c, i) => c + verts[b][i])));
        middle.set(key, verts.length - 1);
      }
      return middle.get(key);
    };
    faces = faces.flatMap(([a, b, c]) => {
      const [ab, bc, ca] = [mid(a, b), mid(b, c), mid(c, a)];
      return [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]];
    });
  }
  return { verts, faces };
}

function float32Bytes(values) {
  const buf = Buffer.alloc(4 * values.length);
  values.forEach((v, i) => buf.writeFloatLE(v, 4 * i));
  return buf;
}

// The float32 positions [x0, y0, z0, x1, ...] of point i of Draco bytes, decoded by Debian's
// draco_decoder to a binary PLY of float x, y, z vertices.
function decodePositions(dir, name, data) {
  const drc = path.join(dir, `${name}.drc`);
  const ply = path.join(dir, `${name}.ply`);
  fs.writeFileSync(drc, data);
  execFileSync('draco_decoder', ['-i', drc, '-o', ply], { stdio: ['ignore', 'ignore', 'pipe'] });
  const raw = fs.readFileSync(ply);
  const end = raw.indexOf('end_header\n') + 'end_header\n'.length;
  const header = raw.subarray(0, end).toString('ascii').split('\n');
  require(header.includes('format binary_little_endian 1.0'), `${name}.ply is not binary little-endian`);
  const v = header.findIndex((line) => line.startsWith('element vertex '));
  const count = Number(header[v].split(' ')[2]);
  const properties = [];
  for (let i = v + 1; header[i].startsWith('property'); i++) properties.push(header[i]);
  require(properties.join(', ') === 'property float x, property float y, property float z',
    `${name}.ply's vertices are not float x, y, z alone: ${properties.join(', ')}`);
  return Array.from({ length: 3 * count }, (_, i) => raw.readFloatLE(end + 4 * i));
}

// The noisy icosphere (642 vertices) as Draco bytes with two GENERIC attributes named by their
// metadata: STRENGTH (0 below z = -0.3, 1 above z = 0.3, linear between) and OVER. Debian's
// draco_encoder writes no such attribute, so the meshsmooth CLI converts a PLY with these float
// properties: its encoder writes each vertex property as one, and --region around a point far
// from the mesh gives every vertex strength 0 in its own job, so its .drc holds the positions as
// they went in. Both are checked, not assumed: draco_decoder reads the same float32 positions
// back in order, and the bytes hold each property's float32 values in vertex order (a lossless
// sequential encoding stores a float attribute's values as they are).
function makeStrengthUpload(dir, cli) {
  const { verts, faces } = icosphere(3);
  let seed = 1;
  const random = () => { seed = (seed * 1103515245 + 12345) % 2147483648; return seed / 2147483648; };
  const points = verts.map((p) => p.map((c) => Math.fround(c + 0.04 * (random() - 0.5))));
  const strength = points.map(([, , z]) => Math.fround(Math.min(1, Math.max(0, (z + 0.3) / 0.6))));
  const over = points.map((_, i) => (i === 7 ? 1.5 : 0.25));
  const lines = ['ply', 'format ascii 1.0', `element vertex ${points.length}`, 'property float x', 'property float y',
    'property float z', `property float ${STRENGTH}`, `property float ${OVER}`, `element face ${faces.length}`,
    'property list uchar int vertex_indices', 'end_header'];
  // A float32 value's shortest decimal reads back as that float32.
  points.forEach((p, i) => lines.push(`${p.join(' ')} ${strength[i]} ${over[i]}`));
  faces.forEach((f) => lines.push(`3 ${f.join(' ')}`));
  const ply = path.join(dir, 'strength.ply');
  const drc = path.join(dir, 'strength.drc');
  fs.writeFileSync(ply, `${lines.join('\n')}\n`);
  execFileSync(cli, ['smooth', ply, '--flow', 'laplacian', '--iterations', '1', '--region', 'sphere:100,100,100,1',
    '--quiet', '-o', drc], { stdio: ['ignore', 'ignore', 'pipe'] });
  const data = fs.readFileSync(drc);
  const decoded = decodePositions(dir, 'strength_upload', data);
  require(decoded.length === 3 * points.length && decoded.every((c, i) => c === points[Math.floor(i / 3)][i % 3]),
    "the CLI's .drc does not hold the PLY's positions bit for bit, in order");
  require(data.includes(float32Bytes(strength)), `the CLI's .drc does not hold the values of '${STRENGTH}'`);
  require(data.includes(float32Bytes(over)), `the CLI's .drc does not hold the values of '${OVER}'`);
  return { data, positions: decoded, strength };
}

// ---------------------------------------------------------------------------------------------
// meshsmoothd

// Starts meshsmoothd on 127.0.0.1:0 and resolves with {proc, address} once it printed its ready
// line; its stderr (the job log) goes to ours.
function startServer(binary) {
  return new Promise((resolve, reject) => {
    const proc = spawn(binary, ['--listen', '127.0.0.1:0', '--workers', '2'], { stdio: ['ignore', 'pipe', 'inherit'] });
    const timer = setTimeout(() => {
      proc.kill('SIGKILL');
      reject(new CheckFailed('no ready line within 30 s'));
    }, 30000);
    let seen = '';
    proc.on('error', (e) => { clearTimeout(timer); reject(e); });
    proc.on('exit', (code) => {
      clearTimeout(timer);
      reject(new CheckFailed(`exited (${code}) before its ready line`));
    });
    proc.stdout.on('data', (chunk) => {
      seen += chunk;
      const m = seen.match(/^meshsmoothd listening on (\S+):(\d+)$/m);
      if (m) {
        clearTimeout(timer);
        proc.removeAllListeners('exit');
        resolve({ proc, address: `${m[1]}:${m[2]}` });
      }
    });
  });
}

// SIGTERM; resolves with the exit code, or 'killed' after 10 s.
function stopServer(proc) {
  return new Promise((resolve) => {
    if (proc.exitCode !== null) { resolve(proc.exitCode); return; }
    const timer = setTimeout(() => { proc.kill('SIGKILL'); resolve('killed'); }, 10000);
    proc.on('exit', (code) => { clearTimeout(timer); resolve(code); });
    proc.kill('SIGTERM');
  });
}

// ---------------------------------------------------------------------------------------------

// {server, cli, proto} from the command line; exits 2 with the usage for anything else.
function parseArgs(argv) {
  const args = {};
  for (let i = 0; i + 1 < argv.length; i += 2) {
    if (['--server', '--cli', '--proto'].includes(argv[i])) args[argv[i].slice(2)] = argv[i + 1];
  }
  if (argv.length !== 6 || Object.keys(args).length !== 3) {
    console.error('usage: e2e_client_test.mjs --server MESHSMOOTHD --cli MESHSMOOTH --proto SMOOTHING_PROTO');
    process.exit(2);
  }
  return args;
}

async function checkListFlows(session) {
  const { status, message, replies } = await call(session, 'ListFlows', [Buffer.alloc(0)]);
  require(status === 0, `status ${status} '${message}'`);
  require(replies.length === 1, `${replies.length} replies`);
  const flows = decode('ListFlowsResponse', replies[0]).flows ?? [];
  const names = flows.map((f) => decode('FlowInfo', f).name?.[0]?.toString('utf8')).sort();
  require(names.join(',') === EXPECTED_FLOWS.join(','), `flows ${names.join(', ')}`);
}

// laplacian, 10 iterations, with STRENGTH: OK, the summary's flow and count, the result's positions.
async function strengthJob(session, dir, upload) {
  const spec = { flow: 'laplacian', iterations: 10, strength_attribute: STRENGTH };
  const { status, message, replies } = await call(session, 'Smooth', smoothRequests(spec, upload.data));
  require(status === 0, `status ${status} '${message}'`);
  const responses = replies.map((r) => decode('SmoothResponse', r));
  const kinds = responses.map((r) => Object.keys(r)[0]);
  require(kinds[0] === 'accepted' && kinds.at(-1) === 'summary', `responses ${kinds.join(', ')}`);
  const summary = decode('Summary', responses.at(-1).summary[0]);
  const parameters = decode('EffectiveParameters', summary.parameters[0]);
  require(parameters.flow?.[0]?.toString('utf8') === 'laplacian' && parameters.iterations_run?.[0] === 10,
    `ran ${parameters.flow?.[0]} for ${parameters.iterations_run?.[0]} iterations`);
  const result = Buffer.concat(responses.filter((r) => r.result_chunk).map((r) => r.result_chunk[0]));
  require(summary.result_bytes?.[0] === result.length,
    `summary.result_bytes ${summary.result_bytes?.[0]}, ${result.length} received`);
  return { result, positions: decodePositions(dir, 'strength_result', result) };
}

// The vertices whose strength is `value` and, of those, the ones whose position changed.
function changedOf(upload, after, value) {
  const vertices = upload.strength.flatMap((s, i) => (s === value ? [i] : []));
  const changed = vertices.filter((i) => [0, 1, 2].some((c) => after[3 * i + c] !== upload.positions[3 * i + c]));
  return { vertices, changed };
}

// The same job without strength_attribute moves the vertices of strength 0: what keeps them is
// the strength, not the flow.
async function checkControl(session, dir, upload) {
  const spec = { flow: 'laplacian', iterations: 10 };
  const { status, message, replies } = await call(session, 'Smooth', smoothRequests(spec, upload.data));
  require(status === 0, `status ${status} '${message}'`);
  const result = Buffer.concat(replies.map((r) => decode('SmoothResponse', r).result_chunk?.[0] ?? Buffer.alloc(0)));
  const { vertices, changed } = changedOf(upload, decodePositions(dir, 'strength_control', result), 0);
  require(changed.length === vertices.length,
    `${vertices.length - changed.length} of ${vertices.length} vertices of strength 0 did not move without it`);
}

async function expectInvalidStrength(session, upload, attribute) {
  const spec = { flow: 'laplacian', iterations: 10, strength_attribute: attribute };
  const { status, message } = await call(session, 'Smooth', smoothRequests(spec, upload.data));
  require(status === GRPC_INVALID_ARGUMENT, `status ${status} '${message}', expected 3 (INVALID_ARGUMENT)`);
  for (const word of ['strength_attribute', attribute]) {
    require(message.includes(word), `message '${message}' does not name ${word}`);
  }
}

async function main() {
  const args = parseArgs(process.argv.slice(2));
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'meshsmooth-node-e2e-'));
  await check('the field numbers of this client are those of smoothing.proto',
    () => checkFieldNumbers(fs.readFileSync(args.proto, 'utf8')));
  const upload = await check("strength upload: the CLI's .drc of a PLY with float properties holds its positions "
    + 'bit for bit and each property as an attribute', () => makeStrengthUpload(dir, args.cli));
  const server = await check('server starts and prints its ready line', () => startServer(args.server));
  if (server) {
    const session = http2.connect(`http://${server.address}`);
    session.on('error', (e) => console.log(`http2 session error: ${e.message}`));
    await check('ListFlows names exactly the 8 flows', () => checkListFlows(session));
    if (upload) {
      const job = await check(`strength: laplacian, 10 iterations, strength_attribute '${STRENGTH}' ends OK`,
        () => strengthJob(session, dir, upload));
      if (job) {
        await check('strength: every vertex of strength 0 comes back bit for bit', () => {
          const { vertices, changed } = changedOf(upload, job.positions, 0);
          require(job.positions.length === upload.positions.length, 'not one point back per point sent');
          require(vertices.length > 100 && changed.length === 0,
            `${changed.length} of ${vertices.length} vertices of strength 0 moved, e.g. ${changed.slice(0, 5)}`);
        });
        await check('strength: every vertex of strength 1 moves', () => {
          const { vertices, changed } = changedOf(upload, job.positions, 1);
          require(vertices.length > 100 && changed.length === vertices.length,
            `${vertices.length - changed.length} of ${vertices.length} vertices of strength 1 did not move`);
        });
        await check('strength: the attribute comes back unchanged (its float32 values in vertex order)',
          () => require(job.result.includes(float32Bytes(upload.strength)), "the result lacks the strength's values"));
      }
      await check('strength: without strength_attribute the vertices of strength 0 move (control)',
        () => checkControl(session, dir, upload));
      await check('error: strength_attribute naming no attribute of the upload -> INVALID_ARGUMENT naming it',
        () => expectInvalidStrength(session, upload, 'no_such_attribute'));
      await check('error: strength_attribute with a value of 1.5 -> INVALID_ARGUMENT naming it',
        () => expectInvalidStrength(session, upload, OVER));
    }
    session.close();
    const code = await stopServer(server.proc);
    await check('server exits cleanly on SIGTERM within 10 s', () => require(code === 0, `exit ${code}`));
  }
  console.log(`${passed} passed, ${failed} failed`);
  if (failed === 0 && passed > 0) {
    fs.rmSync(dir, { recursive: true, force: true });
  } else {
    console.log(`files kept in ${dir}`);
  }
  process.exitCode = failed === 0 && passed > 0 ? 0 : 1;
}

await main();
