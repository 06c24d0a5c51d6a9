#!/usr/bin/env node
// An independent MAVLink peer for the libs/link tests, built on node-mavlink
// (a separate implementation generated from the same XML definitions).
//
//   node peer.js decode [--key HEX64]
//     stdin: frames as hexadecimal (whitespace ignored, any number of frames).
//     stdout: one JSON object per frame node-mavlink's splitter accepted:
//       {name, msgid, sysid, compid, seq, payloadLength, signed, linkId,
//        timestamp, signatureValid, fields: {wire_name: value}}
//     then one {summary: {valid, invalid, unknown}} line.
//     uint64 values are printed as decimal strings (JSON numbers are doubles).
//
//   node peer.js encode [--key HEX64] [--link-id N] [--sysid N] [--compid N]
//     stdin: a JSON array of {name: "HEARTBEAT", fields: {wire_name: value}}
//       (fields left out are zero; uint64 values as strings).
//     stdout: one frame per line in hexadecimal, MAVLink 2, signed when a key
//       is given (timestamps from the clock, 1 ms apart within the burst).
//
// Exit code 2 with one line on stderr for bad input.
'use strict';

const { PassThrough } = require('stream');
const {
  MavLinkPacketSplitter,
  MavLinkPacketParser,
  MavLinkProtocolV2,
  minimal,
  common,
} = require('node-mavlink');

const REGISTRY = { ...minimal.REGISTRY, ...common.REGISTRY };
const BY_NAME = {};
for (const clazz of Object.values(REGISTRY)) BY_NAME[clazz.MSG_NAME] = clazz;

function fail(message) {
  process.stderr.write(`peer.js: ${message}\n`);
  process.exit(2);
}

function parseArgs(argv) {
  const options = { mode: argv[0], key: null, linkId: 0, sysid: 1, compid: 1 };
  for (let i = 1; i < argv.length; i += 2) {
    const value = argv[i + 1];
    if (value === undefined) fail(`${argv[i]} needs a value`);
    switch (argv[i]) {
      case '--key':
        if (!/^[0-9a-fA-F]{64}$/.test(value)) fail('--key must be 64 hexadecimal digits');
        options.key = Buffer.from(value, 'hex');
        break;
      case '--link-id': options.linkId = Number(value); break;
      case '--sysid': options.sysid = Number(value); break;
      case '--compid': options.compid = Number(value); break;
      default: fail(`unknown option ${argv[i]}`);
    }
  }
  if (options.mode !== 'decode' && options.mode !== 'encode') fail('usage: peer.js decode|encode [options]');
  return options;
}

function readStdin() {
  return new Promise((resolve, reject) => {
    const chunks = [];
    process.stdin.on('data', (c) => chunks.push(c));
    process.stdin.on('end', () => resolve(Buffer.concat(chunks).toString('utf8')));
    process.stdin.on('error', reject);
  });
}

function jsonValue(value) {
  if (typeof value === 'bigint') return value.toString();
  if (Array.isArray(value)) return value.map(jsonValue);
  return value;
}

async function decode(options, text) {
  const hex = text.replace(/\s+/g, '');
  if (!/^([0-9a-fA-F]{2})*$/.test(hex)) fail('stdin is not hexadecimal');
  const source = new PassThrough();
  const splitter = new MavLinkPacketSplitter();
  const reader = source.pipe(splitter).pipe(new MavLinkPacketParser());
  const done = new Promise((resolve) => reader.on('end', resolve));
  reader.on('data', (packet) => {
    const clazz = REGISTRY[packet.header.msgid];
    const out = {
      name: clazz ? clazz.MSG_NAME : null,
      msgid: packet.header.msgid,
      sysid: packet.header.sysid,
      compid: packet.header.compid,
      seq: packet.header.seq,
      payloadLength: packet.header.payloadLength,
      signed: packet.signature !== null,
      linkId: packet.signature ? packet.signature.linkId : null,
      timestamp: packet.signature ? packet.signature.timestamp : null,
      signatureValid: packet.signature && options.key ? packet.signature.matches(options.key) : null,
      fields: {},
    };
    if (clazz) {
      const data = packet.protocol.data(packet.payload, clazz);
      for (const field of clazz.FIELDS) out.fields[field.source] = jsonValue(data[field.name]);
    }
    process.stdout.write(JSON.stringify(out) + '\n');
  });
  source.end(Buffer.from(hex, 'hex'));
  await done;
  process.stdout.write(JSON.stringify({
    summary: {
      valid: splitter.validPackages,
      invalid: splitter.invalidPackages,
      unknown: splitter.unknownPackagesCount,
    },
  }) + '\n');
}

function encode(options, text) {
  let specs;
  try {
    specs = JSON.parse(text);
  } catch (e) {
    fail(`stdin is not JSON: ${e.message}`);
  }
  if (!Array.isArray(specs)) fail('stdin must be a JSON array');
  const flags = options.key ? MavLinkProtocolV2.IFLAG_SIGNED : 0;
  const protocol = new MavLinkProtocolV2(options.sysid, options.compid, flags);
  let seq = 0;
  // node-mavlink signs with millisecond timestamps; a receiver rejects a
  // timestamp that does not increase, so frames of one burst get 1 ms steps.
  const start = Date.now();
  for (const spec of specs) {
    const clazz = BY_NAME[spec.name];
    if (!clazz) fail(`unknown message ${spec.name}`);
    const message = new clazz();
    // Start from all zeros (the generated defaults are the first enum
    // entries, which need not be 0) and then set what the spec gives.
    for (const field of clazz.FIELDS) {
      if (field.type === 'uint64_t' || field.type === 'int64_t') message[field.name] = 0n;
      else if (field.type === 'char[]') message[field.name] = '';
      else if (field.length > 0) message[field.name] = new Array(field.length).fill(0);
      else message[field.name] = 0;
    }
    const bySource = {};
    for (const field of clazz.FIELDS) bySource[field.source] = field;
    for (const [source, value] of Object.entries(spec.fields || {})) {
      const field = bySource[source];
      if (!field) fail(`${spec.name} has no field ${source}`);
      message[field.name] = field.type.endsWith('64_t') ? BigInt(value) : value;
    }
    let frame = protocol.serialize(message, seq);
    if (options.key) frame = protocol.sign(frame, options.linkId, options.key, start + seq);
    seq = (seq + 1) & 255;
    process.stdout.write(frame.toString('hex') + '\n');
  }
}

async function main() {
  const options = parseArgs(process.argv.slice(2));
  const text = await readStdin();
  if (options.mode === 'decode') await decode(options, text);
  else encode(options, text);
}

main().catch((e) => fail(e.stack || String(e)));
