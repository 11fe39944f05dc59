// The viewer's pixels: OpenEXR decoding (what `caustica serve` writes: single-part scanline or
// tiled images, uncompressed, RLE or ZIP, half or float channels), exposure and tone mapping
// as the server's PNG encoder does them (so a frame's exposure changes without a new render),
// and a false-colour error map of one frame against another.

/** A frame's linear radiance: `rgb` holds width × height RGB triples, top row first. */
export interface Radiance {
  width: number;
  height: number;
  rgb: Float32Array;
}

/** The tone maps of the server's PNG output (`tone_map`). */
export type ToneMap = "clamp" | "aces" | "reinhard";

// Not in the DOM types of Debian's tsc 4.8; every browser the viewer targets has it.
declare class DecompressionStream {
  constructor(format: "deflate");
  readonly readable: ReadableStream<Uint8Array>;
  readonly writable: WritableStream<Uint8Array>;
}

const COMPRESSIONS = ["none", "rle", "zips", "zip"];

/** Decodes an OpenEXR file's R, G and B channels (others are skipped). Throws on anything
 *  else: multi-part or deep files, mip-mapped tiles, other compressions. */
export async function decodeExr(bytes: Uint8Array): Promise<Radiance> {
  const v = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  if (bytes.length < 8 || v.getUint32(0, true) !== 20000630) throw new Error("not an OpenEXR file");
  const flags = v.getUint32(4, true) >> 8;
  if (flags & 0x18) throw new Error("multi-part and deep EXR files are not supported");
  let p = 8;
  const cstr = (): string => {
    const end = bytes.indexOf(0, p);
    if (end < 0) throw new Error("EXR header cut short");
    const s = new TextDecoder().decode(bytes.subarray(p, end));
    p = end + 1;
    return s;
  };
  const attrs = new Map<string, { type: string; at: number; size: number }>();
  while (bytes[p] !== 0) {
    const name = cstr();
    const type = cstr();
    const size = v.getInt32(p, true);
    attrs.set(name, { type, at: p + 4, size });
    p += 4 + size;
    if (p > bytes.length) throw new Error("EXR header cut short");
  }
  p += 1;
  const attr = (name: string) => {
    const a = attrs.get(name);
    if (!a) throw new Error(`EXR header has no ${name}`);
    return a;
  };
  // Channels: name, pixel type (0 uint, 1 half, 2 float), sampling (must be 1, 1).
  const channels: { name: string; type: number }[] = [];
  {
    const a = attr("channels");
    let q = a.at;
    while (bytes[q] !== 0) {
      const end = bytes.indexOf(0, q);
      const name = new TextDecoder().decode(bytes.subarray(q, end));
      q = end + 1;
      const type = v.getInt32(q, true);
      if (v.getInt32(q + 8, true) !== 1 || v.getInt32(q + 12, true) !== 1) {
        throw new Error(`EXR channel ${name} is subsampled`);
      }
      channels.push({ name, type });
      q += 16;
    }
  }
  const compression = COMPRESSIONS[bytes[attr("compression").at]];
  if (!compression) throw new Error(`EXR compression ${bytes[attr("compression").at]} is not supported`);
  const dw = attr("dataWindow").at;
  const [x0, y0, x1, y1] = [0, 4, 8, 12].map((o) => v.getInt32(dw + o, true));
  const width = x1 - x0 + 1;
  const height = y1 - y0 + 1;
  if (width <= 0 || height <= 0 || width * height > 1 << 26) throw new Error("EXR size out of range");
  const tiles = attrs.get("tiles");
  let tw = width;
  let th = compression === "zip" ? 16 : 1;
  if (tiles) {
    tw = v.getUint32(tiles.at, true);
    th = v.getUint32(tiles.at + 4, true);
    if ((bytes[tiles.at + 8] & 0xf) !== 0) throw new Error("mip-mapped EXR tiles are not supported");
  }
  const across = tiles ? Math.ceil(width / tw) : 1;
  const chunks = across * Math.ceil(height / th);
  const bpp = (t: number) => (t === 1 ? 2 : 4);
  const rgb = new Float32Array(width * height * 3);
  const slot: Record<string, number> = { R: 0, G: 1, B: 2 };
  for (let c = 0; c < chunks; c++) {
    let q = Number(v.getBigUint64(p + 8 * c, true));
    let bx = 0;
    let by: number;
    if (tiles) {
      bx = v.getInt32(q, true) * tw;
      by = v.getInt32(q + 4, true) * th;
      q += 16;
    } else {
      by = v.getInt32(q, true) - y0;
      q += 4;
    }
    const size = v.getInt32(q, true);
    q += 4;
    if (q + size > bytes.length) throw new Error("EXR chunk cut short");
    const w = Math.min(tw, width - bx);
    const h = Math.min(th, height - by);
    const raw = w * h * channels.reduce((s, ch) => s + bpp(ch.type), 0);
    let data = bytes.subarray(q, q + size);
    if (size < raw) data = await inflate(data, compression, raw);
    if (data.length !== raw) throw new Error("EXR chunk has the wrong size");
    const d = new DataView(data.buffer, data.byteOffset, data.byteLength);
    // Per line of the block, each channel's values for that line.
    let o = 0;
    for (let y = 0; y < h; y++) {
      for (const ch of channels) {
        const s = slot[ch.name];
        for (let x = 0; x < w; x++) {
          let f: number;
          if (ch.type === 2) f = d.getFloat32(o, true);
          else if (ch.type === 1) f = half(d.getUint16(o, true));
          else f = d.getUint32(o, true);
          o += bpp(ch.type);
          if (s !== undefined) rgb[((by + y) * width + bx + x) * 3 + s] = f;
        }
      }
    }
  }
  return { width, height, rgb };
}

/** A compressed block of `raw` bytes, decompressed and its bytes put back in order. */
async function inflate(data: Uint8Array, compression: string, raw: number): Promise<Uint8Array> {
  let t: Uint8Array;
  if (compression === "rle") {
    t = new Uint8Array(raw);
    let i = 0;
    let o = 0;
    while (i < data.length) {
      const n = (data[i] << 24) >> 24;
      if (n < 0) {
        if (o - n > raw) throw new Error("EXR RLE data overflows its block");
        t.set(data.subarray(i + 1, i + 1 - n), o);
        o -= n;
        i += 1 - n;
      } else {
        if (o + n + 1 > raw) throw new Error("EXR RLE data overflows its block");
        t.fill(data[i + 1], o, o + n + 1);
        o += n + 1;
        i += 2;
      }
    }
    if (o !== raw) throw new Error("EXR RLE data falls short of its block");
  } else if (compression === "zip" || compression === "zips") {
    const s = new Blob([data]).stream().pipeThrough(new DecompressionStream("deflate") as never);
    t = new Uint8Array(await new Response(s).arrayBuffer());
    if (t.length !== raw) throw new Error("EXR ZIP data does not fill its block");
  } else {
    throw new Error("EXR block is compressed but the file says it is not");
  }
  // Undo the predictor (each byte stored as its difference from the last), then the split of
  // the bytes into the even ones followed by the odd ones.
  for (let i = 1; i < t.length; i++) t[i] = (t[i - 1] + t[i] - 128) & 0xff;
  const out = new Uint8Array(raw);
  const half = (raw + 1) >> 1;
  for (let i = 0; i < raw; i++) out[i] = i & 1 ? t[half + (i >> 1)] : t[i >> 1];
  return out;
}

/** An IEEE 754 half's value. */
function half(h: number): number {
  const s = h & 0x8000 ? -1 : 1;
  const e = (h >> 10) & 0x1f;
  const m = h & 0x3ff;
  if (e === 0) return s * m * 2 ** -24;
  if (e === 31) return m ? NaN : s * Infinity;
  return s * (1 + m / 1024) * 2 ** (e - 15);
}

const f32 = Math.fround;

// The server's constants, as single-precision floats.
const [A, B, C, D, E] = [2.51, 0.03, 2.43, 0.59, 0.14].map(f32);
const INV_GAMMA = f32(1 / 2.4);

/** The server's tone map of one channel (`encode::tone_map`), in single precision as it is. */
function tone(x: number, t: ToneMap): number {
  x = Math.max(x, 0);
  if (t === "clamp") return Math.min(x, 1);
  if (t === "reinhard") return f32(x / f32(1 + x));
  const n = f32(x * f32(f32(A * x) + B));
  const d = f32(f32(x * f32(f32(C * x) + D)) + E);
  return Math.min(Math.max(f32(n / d), 0), 1);
}

function srgb(x: number): number {
  return x <= f32(0.0031308) ? f32(f32(12.92) * x) : f32(f32(f32(1.055) * f32(x ** INV_GAMMA)) - f32(0.055));
}

/** 8-bit sRGB pixels of `f` at `exposure` stops through `t`: the server's PNG of the same
 *  frame and settings, to within one step of rounding. */
export function toneMapped(f: Radiance, exposure: number, t: ToneMap): ImageData {
  const k = f32(2 ** exposure);
  const img = new ImageData(f.width, f.height);
  const n = f.width * f.height;
  for (let i = 0; i < n; i++) {
    for (let c = 0; c < 3; c++) {
      const s = srgb(tone(f32(f.rgb[i * 3 + c] * k), t));
      img.data[i * 4 + c] = Math.min(255, Math.max(0, Math.trunc(f32(f32(s * 255) + 0.5))));
    }
    img.data[i * 4 + 3] = 255;
  }
  return img;
}

const luminance = (f: Radiance, i: number) =>
  0.2126 * f.rgb[i * 3] + 0.7152 * f.rgb[i * 3 + 1] + 0.0722 * f.rgb[i * 3 + 2];

/** Per pixel, |L(a) − L(b)| in units of b's mean luminance (L: luminance), as a colour ramp
 *  from black (0) through red and yellow to white (1 or more); and that mean error. */
export function errorMap(a: Radiance, b: Radiance): { image: ImageData; mean: number } {
  if (a.width !== b.width || a.height !== b.height) throw new Error("the frames differ in size");
  const n = a.width * a.height;
  let scale = 0;
  for (let i = 0; i < n; i++) scale += luminance(b, i);
  scale = scale / n || 1;
  const img = new ImageData(a.width, a.height);
  let sum = 0;
  for (let i = 0; i < n; i++) {
    const e = Math.abs(luminance(a, i) - luminance(b, i)) / scale;
    sum += e;
    const x = Math.min(e, 1) * 3;
    img.data.set(
      [255 * Math.min(x, 1), 255 * Math.min(Math.max(x - 1, 0), 1), 255 * Math.max(x - 2, 0), 255],
      i * 4,
    );
  }
  return { image: img, mean: sum / n };
}
