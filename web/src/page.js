// The results page of `multibond plot`: every column of results.csv, plotted with uPlot; the
// energy account; the run's events on every plot against time; the bond graph, clickable; and,
// for mechanisms, a 3D view of the bodies with three.js. The data is the JSON that
// `multibond plot` puts into index.html (<script type="application/json" id="mb-data">).
//
// Safety: every text that comes from the results folder or the model (names, units, events,
// labels) reaches the page through textContent, setAttribute of checked values, or a canvas
// (docs/security.md). Nothing is fetched: the page works from file:// without a network.

import uPlot from 'uplot';
import 'uplot/dist/uPlot.min.css';
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import './page.css';

const SVGNS = 'http://www.w3.org/2000/svg';
const linearPath = uPlot.paths.linear();
const PALETTE = ['#1f77b4', '#d62728', '#2ca02c', '#ff7f0e', '#9467bd', '#8c564b', '#e377c2', '#7f7f7f', '#bcbd22', '#17becf',
  '#003f5c', '#a05195'];
const MAX_DISPLAY_POINTS = 2000;  // per series on screen (min/max per bucket); exports use every row
const MAX_LIST_ROWS = 3000;       // column list rows shown at once

// ---------------------------------------------------------------------------------------------
// DOM helpers: elements with text only.

function el(tag, attrs = {}, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k === 'text') e.textContent = v;
    else if (k === 'class') e.className = v;
    else if (k.startsWith('on')) e.addEventListener(k.slice(2), v);
    else e.setAttribute(k, v);
  }
  for (const c of children) if (c) e.append(c);
  return e;
}

function svgEl(tag, attrs = {}) {
  const e = document.createElementNS(SVGNS, tag);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, String(v));
  return e;
}

function fmtNum(v) {
  if (v === null || v === undefined || Number.isNaN(v)) return 'n/a';
  if (v === 0) return '0';
  const a = Math.abs(v);
  return a >= 1e-3 && a < 1e6 ? Number(v.toPrecision(5)).toString() : v.toExponential(4);
}

/** An axis tick: short, exact enough to tell neighbours apart (uPlot's default rounds 1e-5 to 0). */
function fmtTick(v) {
  if (v === 0) return '0';
  const a = Math.abs(v);
  return a >= 1e-3 && a < 1e5 ? Number(v.toPrecision(6)).toString() : v.toExponential(2).replace(/\.?0+e/, 'e');
}

function safeFileName(s) {
  return String(s).replace(/[^A-Za-z0-9_.-]+/g, '_').slice(0, 80) || 'plot';
}

function download(name, blob) {
  const a = el('a', { download: name });
  a.href = URL.createObjectURL(blob);
  document.body.append(a);
  a.click();
  setTimeout(() => { URL.revokeObjectURL(a.href); a.remove(); }, 1000);
}

// ---------------------------------------------------------------------------------------------
// The data.

const timings = { start: performance.now() };
const raw = JSON.parse(document.getElementById('mb-data').textContent);
const columns = raw.columns.map((c, i) => ({ index: i, name: String(c.name), unit: String(c.unit) }));
/** A column: base64 of little-endian IEEE doubles (plot_web.h, Base64Doubles). */
function decodeColumn(b64) {
  let bytes;
  if (typeof Uint8Array.fromBase64 === 'function') bytes = Uint8Array.fromBase64(b64);
  else {
    const s = atob(b64);
    bytes = new Uint8Array(s.length);
    for (let i = 0; i < s.length; ++i) bytes[i] = s.charCodeAt(i);
  }
  return new Float64Array(bytes.buffer, bytes.byteOffset, bytes.length / 8);
}
timings.parsed = performance.now();
const values = raw.values.map(decodeColumn);
timings.decoded = performance.now();
const rows = values.length ? values[0].length : 0;
const time = values[0] || new Float64Array(0);
const byName = new Map(columns.map(c => [c.name, c.index]));
const events = Array.isArray(raw.events) ? raw.events : [];
const col = name => (byName.has(name) ? values[byName.get(name)] : null);
const label = c => `${c.name} [${c.unit}]`;
const elementOf = name => { const d = name.indexOf('.'); return d < 0 ? 'outputs' : name.slice(0, d); };

/** Index of the last row with time <= t (binary search). */
function rowAt(t) {
  let lo = 0, hi = rows - 1;
  if (rows === 0) return 0;
  if (t <= time[0]) return 0;
  if (t >= time[hi]) return hi;
  while (hi - lo > 1) {
    const mid = (lo + hi) >> 1;
    if (time[mid] <= t) lo = mid; else hi = mid;
  }
  return lo;
}

/** Rows to draw for x against time: every row when few, else first/min/max/last of each bucket. */
function displayRows(ys, i0 = 0, i1 = rows - 1) {
  const n = i1 - i0 + 1;
  if (n <= MAX_DISPLAY_POINTS) return null;
  const buckets = Math.max(1, Math.floor(MAX_DISPLAY_POINTS / 4));
  const keep = new Uint8Array(rows);
  for (let b = 0; b < buckets; ++b) {
    const s = i0 + Math.floor((b * n) / buckets), e = i0 + Math.floor(((b + 1) * n) / buckets) - 1;
    if (e < s) continue;
    keep[s] = 1; keep[e] = 1;
    for (const y of ys) {
      const v = values[y];
      let lo = s, hi = s;
      for (let i = s + 1; i <= e; ++i) {
        if (v[i] < v[lo]) lo = i;
        if (v[i] > v[hi]) hi = i;
      }
      keep[lo] = 1; keep[hi] = 1;
    }
  }
  const out = [];
  for (let i = 0; i < rows; ++i) if (keep[i]) out.push(i);
  return out;
}

// ---------------------------------------------------------------------------------------------
// Shared time: the plots' cursor, the scrub bar, the 3D view and the graph's colours.

const timeListeners = [];
let currentRow = 0;
let settingTime = false;
function setRow(r, from) {
  if (settingTime) return;
  settingTime = true;
  try {
    currentRow = Math.max(0, Math.min(rows - 1, r));
    for (const f of timeListeners) f(currentRow, from);
  } finally {
    settingTime = false;
  }
}

// ---------------------------------------------------------------------------------------------
// Plots.

const plots = [];  // {u, timeX, panel, spec, idx, title, lines}

function eventsPlugin(entry) {
  return {
    hooks: {
      // Behind the curves: drawn after the canvas is cleared, before the axes and series.
      drawClear: u => {
        entry.eventLines = 0;
        if (!events.length) return;
        const { ctx } = u;
        const { top, height } = u.bbox;
        const [xmin, xmax] = [u.scales.x.min, u.scales.x.max];
        const used = new Set();
        ctx.save();
        ctx.lineWidth = Math.max(1, devicePixelRatio);
        for (const e of events) {
          if (!(e.time >= xmin && e.time <= xmax)) continue;
          const x = Math.round(u.valToPos(e.time, 'x', true));
          if (used.has(x)) continue;  // thinned: one line a pixel column
          used.add(x);
          entry.eventLines += 1;
          ctx.strokeStyle = /^#[0-9a-fA-F]{6}$/.test(e.color) ? e.color : '#888888';
          ctx.setLineDash(e.kind === 'impact' ? [] : [4, 3]);
          ctx.beginPath();
          ctx.moveTo(x, top);
          ctx.lineTo(x, top + height);
          ctx.stroke();
        }
        ctx.restore();
      },
    },
  };
}

function wheelZoomPlugin() {
  return {
    hooks: {
      ready: u => {
        const over = u.over;
        over.addEventListener('wheel', ev => {
          ev.preventDefault();
          const { min, max } = u.scales.x;
          if (!(max > min)) return;
          const at = u.posToVal(ev.offsetX, 'x');
          const k = ev.deltaY < 0 ? 0.8 : 1.25;
          u.setScale('x', { min: at - (at - min) * k, max: at + (max - at) * k });
        }, { passive: false });
        // Pan: shift + drag.
        over.addEventListener('mousedown', ev => {
          if (!ev.shiftKey) return;
          ev.preventDefault();
          ev.stopPropagation();
          const x0 = ev.clientX, { min, max } = u.scales.x;
          const perPx = (max - min) / u.bbox.width * devicePixelRatio;
          const move = e => { const d = (e.clientX - x0) * perPx; u.setScale('x', { min: min - d, max: max - d }); };
          const up = () => { window.removeEventListener('mousemove', move); window.removeEventListener('mouseup', up); };
          window.addEventListener('mousemove', move);
          window.addEventListener('mouseup', up);
        }, true);
      },
    },
  };
}

/** The data uPlot draws: x then each y, over the rows chosen for display. */
function plotData(x, ys) {
  const sel = x === 0 ? displayRows(ys) : null;
  if (x !== 0) {
    // Against another column: every n-th row (a path), at most MAX_DISPLAY_POINTS * 2.
    const stride = Math.max(1, Math.ceil(rows / (MAX_DISPLAY_POINTS * 2)));
    const idx = [];
    for (let i = 0; i < rows; i += stride) idx.push(i);
    if (idx[idx.length - 1] !== rows - 1) idx.push(rows - 1);
    return { idx, data: [x, ...ys].map(c => Float64Array.from(idx, i => values[c][i])) };
  }
  if (!sel) return { idx: null, data: [x, ...ys].map(c => values[c]) };
  return { idx: sel, data: [x, ...ys].map(c => Float64Array.from(sel, i => values[c][i])) };
}

function addPlot(spec, container = document.getElementById('mb-plots'), prepend = true) {
  const { x, ys } = spec;
  const title = spec.title || (x === 0 ? ys.map(c => columns[c].name).join(', ') : `${ys.map(c => columns[c].name).join(', ')} against ${columns[x].name}`);
  const panel = el('div', { class: 'mb-panel mb-plot' });
  const head = el('div', { class: 'mb-panel-head' }, el('span', { class: 'mb-title', text: title }));
  const body = el('div', { class: 'mb-plot-body' });
  panel.append(head, body);
  if (prepend) container.prepend(panel); else container.append(panel);
  const units = [...new Set(ys.map(c => columns[c].unit))];
  const { idx, data } = plotData(x, ys);
  const timeX = x === 0;
  const width = Math.max(300, body.clientWidth || container.clientWidth - 20 || 800);
  const holder = { eventLines: 0 };
  const series = [{ label: label(columns[x]), value: (u, v) => (v == null ? '--' : `${fmtNum(v)} ${columns[x].unit}`) }];
  ys.forEach((c, k) => series.push({
    label: label(columns[c]),
    scale: columns[c].unit,
    stroke: PALETTE[k % PALETTE.length],
    width: 1.5,
    points: { show: false },
    // Against another column the data is a path, not sorted by x: draw every point in order
    // (uPlot would clip to the window it finds by bisecting x).
    paths: timeX ? undefined : (u, si) => linearPath(u, si, 0, u.data[0].length - 1),
    value: (u, v) => (v == null ? '--' : `${fmtNum(v)} ${columns[c].unit}`),
  }));
  const axes = [{ label: label(columns[x]) }];
  const ticks = (u, splits) => splits.map(v => (v == null ? '' : fmtTick(v)));
  axes[0].values = ticks;
  units.slice(0, 2).forEach((unit, k) => axes.push({ scale: unit, label: `[${unit}]`, side: k === 0 ? 3 : 1, grid: { show: k === 0 }, values: ticks, size: 60 }));
  const scales = { x: { time: false, auto: true } };
  let fixedRanges = null;
  if (!timeX) {
    // Ranges from every point (uPlot's own would look at the first and last x only).
    const padded = arr => {
      let lo = Infinity, hi = -Infinity;
      for (const a of arr) for (const v of a) if (Number.isFinite(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
      if (!(hi >= lo)) return [0, 1];
      const pad = (hi - lo) * 0.05 || Math.abs(hi) * 0.05 || 1;
      return [lo - pad, hi + pad];
    };
    const xr = padded([data[0]]);
    scales.x = { time: false, auto: false };
    fixedRanges = { x: xr };
    for (const unit of units) {
      const yr = padded(ys.map((c, k) => (columns[c].unit === unit ? data[k + 1] : [])));
      scales[unit] = { auto: false };
      fixedRanges[unit] = yr;
    }
  } else {
    for (const unit of units) scales[unit] = { auto: true };
  }
  const opts = {
    width, height: spec.height || 260,
    series, axes, scales,
    cursor: timeX ? { sync: { key: 'mb-time', setSeries: false }, drag: { x: true, y: false } } : { drag: { x: true, y: true } },
    legend: { live: timeX },  // against a column, the cursor's bisection of x means nothing
    plugins: timeX ? [eventsPlugin(holder), wheelZoomPlugin()] : [wheelZoomPlugin()],
    hooks: {
      setCursor: [u => {
        if (u.cursor.idx == null) return;
        const r = idx ? idx[u.cursor.idx] : u.cursor.idx;
        setRow(r, u);
      }],
    },
  };
  if (spec.bands) opts.bands = spec.bands;
  if (spec.fills) spec.fills.forEach((f, k) => { if (f) { series[k + 1].fill = f; } });
  const u = new uPlot(opts, data, body);
  if (fixedRanges) for (const [k, [min, max]] of Object.entries(fixedRanges)) u.setScale(k, { min, max });
  const entry = { u, timeX, panel, spec, idx, title, lines: holder };
  plots.push(entry);
  const tools = el('span', { class: 'mb-tools' },
    el('button', { type: 'button', text: 'PNG', title: 'save this plot as PNG', onclick: () => exportPng(entry) }),
    el('button', { type: 'button', text: 'SVG', title: 'save this plot as SVG', onclick: () => exportSvg(entry) }),
    el('button', { type: 'button', text: 'CSV', title: 'save these columns (every row) as CSV', onclick: () => exportCsv([x, ...ys]) }),
    el('button', { type: 'button', text: 'reset zoom', onclick: () => {
      if (!fixedRanges) u.setData(u.data, true);
      else for (const [k, [min, max]] of Object.entries(fixedRanges)) u.setScale(k, { min, max });
    } }),
    el('button', { type: 'button', text: '\u00d7', title: 'close', onclick: () => { u.destroy(); panel.remove(); plots.splice(plots.indexOf(entry), 1); } }));
  head.append(tools);
  return entry;
}

function resizePlots() {
  for (const p of plots) {
    const w = Math.max(300, p.panel.clientWidth - 16);
    if (Math.abs(w - p.u.width) > 4) p.u.setSize({ width: w, height: p.u.height });
  }
}

timeListeners.push((r, from) => {
  for (const p of plots) {
    if (!p.timeX || p.u === from) continue;
    const left = p.u.valToPos(time[r], 'x');
    if (left >= 0 && left <= p.u.bbox.width / devicePixelRatio) p.u.setCursor({ left, top: p.u.cursor.top > 0 ? p.u.cursor.top : 10 }, false);
  }
});

// ---------------------------------------------------------------------------------------------
// Export.

function exportCsv(cols) {
  const q = s => (/[",\n\r]/.test(s) ? `"${s.replace(/"/g, '""')}"` : s);
  const lines = [cols.map(c => q(c === 0 ? 'time [s]' : label(columns[c]))).join(',')];
  for (let i = 0; i < rows; ++i) lines.push(cols.map(c => (Number.isNaN(values[c][i]) ? 'nan' : String(values[c][i]))).join(','));
  download('columns.csv', new Blob([lines.join('\n') + '\n'], { type: 'text/csv' }));
}

function exportPng(p) {
  const src = p.u.ctx.canvas;
  const c = document.createElement('canvas');
  c.width = src.width; c.height = src.height + 30 * devicePixelRatio;
  const ctx = c.getContext('2d');
  ctx.fillStyle = '#ffffff';
  ctx.fillRect(0, 0, c.width, c.height);
  ctx.fillStyle = '#222222';
  ctx.font = `${14 * devicePixelRatio}px sans-serif`;
  ctx.fillText(p.title, 10 * devicePixelRatio, 20 * devicePixelRatio);
  ctx.drawImage(src, 0, 30 * devicePixelRatio);
  c.toBlob(b => download(`${safeFileName(p.title)}.png`, b), 'image/png');
}

/** The plot as an SVG document: the same series, axes with the plot's ticks, a key. */
function plotSvg(p) {
  const u = p.u, W = u.width, H = u.height + 40 + 16 * (u.series.length - 1);
  const { left, top, width, height } = u.bbox;
  const d = devicePixelRatio, L = left / d, T = top / d + 24, PW = width / d, PH = height / d;
  const svg = svgEl('svg', { xmlns: SVGNS, width: W, height: H, viewBox: `0 0 ${W} ${H}`, 'font-family': 'sans-serif', 'font-size': 11 });
  svg.append(svgEl('rect', { x: 0, y: 0, width: W, height: H, fill: '#ffffff' }));
  const title = svgEl('text', { x: 10, y: 16, 'font-size': 14 });
  title.textContent = p.title;
  svg.append(title, svgEl('rect', { x: L, y: T, width: PW, height: PH, fill: 'none', stroke: '#888888' }));
  const xs = u.scales.x;
  for (const v of u.axes[0]._splits || []) {
    const x = L + u.valToPos(v, 'x');
    svg.append(svgEl('line', { x1: x, y1: T + PH, x2: x, y2: T + PH + 4, stroke: '#444444' }));
    const t = svgEl('text', { x, y: T + PH + 16, 'text-anchor': 'middle' });
    t.textContent = fmtNum(v);
    svg.append(t);
  }
  const xl = svgEl('text', { x: L + PW / 2, y: T + PH + 32, 'text-anchor': 'middle' });
  xl.textContent = u.series[0].label;
  svg.append(xl);
  for (let k = 1; k < u.series.length; ++k) {
    const s = u.series[k], ys = u.data[k], pts = [];
    for (let i = 0; i < u.data[0].length; ++i) {
      const xv = u.data[0][i], yv = ys[i];
      if (!(xv >= xs.min && xv <= xs.max) || !Number.isFinite(yv)) continue;
      pts.push(`${(L + u.valToPos(xv, 'x')).toFixed(2)},${(T + u.valToPos(yv, s.scale)).toFixed(2)}`);
    }
    const color = typeof s.stroke === 'function' ? s.stroke(u, k) : s.stroke;
    if (pts.length) svg.append(svgEl('polyline', { points: pts.join(' '), fill: 'none', stroke: color || '#000000', 'stroke-width': 1.5 }));
    const key = svgEl('text', { x: 10, y: T + PH + 48 + 16 * (k - 1), fill: color || '#000000' });
    key.textContent = s.label;
    svg.append(key);
  }
  return svg;
}

function exportSvg(p) {
  const text = new XMLSerializer().serializeToString(plotSvg(p));
  download(`${safeFileName(p.title)}.svg`, new Blob([text], { type: 'image/svg+xml' }));
}

// A ZIP file (stored, no compression) of named byte arrays: the 3D view's frames.
const CRC_TABLE = (() => {
  const t = new Uint32Array(256);
  for (let n = 0; n < 256; ++n) { let c = n; for (let k = 0; k < 8; ++k) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1; t[n] = c >>> 0; }
  return t;
})();
function crc32(b) { let c = 0xffffffff; for (let i = 0; i < b.length; ++i) c = CRC_TABLE[(c ^ b[i]) & 0xff] ^ (c >>> 8); return (c ^ 0xffffffff) >>> 0; }
function zipStored(files) {
  const parts = [], central = [];
  let offset = 0;
  const enc = new TextEncoder();
  for (const f of files) {
    const name = enc.encode(f.name), crc = crc32(f.data), size = f.data.length;
    const h = new DataView(new ArrayBuffer(30));
    h.setUint32(0, 0x04034b50, true); h.setUint16(4, 20, true); h.setUint32(14, crc, true);
    h.setUint32(18, size, true); h.setUint32(22, size, true); h.setUint16(26, name.length, true);
    parts.push(new Uint8Array(h.buffer), name, f.data);
    const c = new DataView(new ArrayBuffer(46));
    c.setUint32(0, 0x02014b50, true); c.setUint16(4, 20, true); c.setUint16(6, 20, true); c.setUint32(16, crc, true);
    c.setUint32(20, size, true); c.setUint32(24, size, true); c.setUint16(28, name.length, true); c.setUint32(42, offset, true);
    central.push(new Uint8Array(c.buffer), name);
    offset += 30 + name.length + size;
  }
  const size = central.reduce((s, b) => s + b.length, 0);
  const e = new DataView(new ArrayBuffer(22));
  e.setUint32(0, 0x06054b50, true); e.setUint16(8, files.length, true); e.setUint16(10, files.length, true);
  e.setUint32(12, size, true); e.setUint32(16, offset, true);
  return new Blob([...parts, ...central, new Uint8Array(e.buffer)], { type: 'application/zip' });
}

// ---------------------------------------------------------------------------------------------
// The column list.

const selected = new Set();
function buildColumnList(root) {
  const search = el('input', { type: 'search', placeholder: 'search columns (name or unit)', 'aria-label': 'search columns', id: 'mb-search' });
  const groupBy = el('select', { 'aria-label': 'group by', id: 'mb-groupby' },
    el('option', { value: 'element', text: 'by element' }), el('option', { value: 'unit', text: 'by unit' }));
  const xSel = el('select', { 'aria-label': 'x axis', id: 'mb-x' });
  for (const c of columns) xSel.append(el('option', { value: String(c.index), text: c.index === 0 ? 'time' : c.name }));
  const list = el('div', { class: 'mb-list', id: 'mb-column-list' });
  const count = el('div', { class: 'mb-count' });
  const plotSel = () => {
    if (!selected.size) return;
    const ys = [...selected].filter(c => c !== Number(xSel.value));
    if (ys.length) addPlot({ x: Number(xSel.value), ys });
  };
  root.append(
    el('div', { class: 'mb-list-tools' }, search, groupBy),
    el('div', { class: 'mb-list-tools' },
      el('button', { type: 'button', text: 'plot selected', id: 'mb-plot-selected', onclick: plotSel }),
      el('label', { text: ' against ' }), xSel),
    el('div', { class: 'mb-list-tools' },
      el('button', { type: 'button', text: 'CSV of selected', onclick: () => selected.size && exportCsv([0, ...[...selected].filter(c => c !== 0)]) }),
      el('button', { type: 'button', text: 'clear', onclick: () => { selected.clear(); render(); } })),
    count, list);
  function render() {
    const q = search.value.trim().toLowerCase();
    const groups = new Map();
    let shown = 0, matched = 0;
    for (const c of columns.slice(1)) {
      if (c.synthetic) continue;
      if (q && !c.name.toLowerCase().includes(q) && !c.unit.toLowerCase().includes(q)) continue;
      ++matched;
      const g = groupBy.value === 'unit' ? `[${c.unit}]` : elementOf(c.name);
      if (!groups.has(g)) groups.set(g, []);
      groups.get(g).push(c);
    }
    list.replaceChildren();
    for (const [g, cs] of groups) {
      if (shown >= MAX_LIST_ROWS) break;
      const details = el('details', { open: '' });
      const summary = el('summary', { text: `${g} (${cs.length})` });
      summary.append(el('button', { type: 'button', class: 'mb-mini', text: 'plot', title: 'plot this group against time',
        onclick: ev => { ev.preventDefault(); plotGroup(cs.map(c => c.index)); } }));
      details.append(summary);
      for (const c of cs) {
        if (shown++ >= MAX_LIST_ROWS) break;
        const box = el('input', { type: 'checkbox', 'data-column': c.name });
        box.checked = selected.has(c.index);
        box.addEventListener('change', () => { if (box.checked) selected.add(c.index); else selected.delete(c.index); });
        const name = el('span', { class: 'mb-col-name', text: c.name, title: 'click: plot against time' });
        name.addEventListener('click', () => addPlot({ x: 0, ys: [c.index] }));
        details.append(el('div', { class: 'mb-col' }, box, name, el('span', { class: 'mb-unit', text: ` [${c.unit}]` })));
      }
      list.append(details);
    }
    count.textContent = `${matched} of ${raw.columns.length - 1} columns${shown < matched ? `, first ${shown} listed (narrow the search)` : ''}; ${rows} rows`;
  }
  search.addEventListener('input', render);
  groupBy.addEventListener('change', render);
  render();
}

/** Plots of columns against time, one per unit, at most 12 curves each. */
function plotGroup(cols, prefix) {
  const byUnit = new Map();
  for (const c of cols) {
    const u = columns[c].unit;
    if (!byUnit.has(u)) byUnit.set(u, []);
    byUnit.get(u).push(c);
  }
  const made = [];
  for (const [unit, cs] of [...byUnit].reverse())
    for (let k = 0; k < cs.length; k += 12)
      made.push(addPlot({ x: 0, ys: cs.slice(k, k + 12), title: prefix ? `${prefix} [${unit}]` : undefined }));
  return made;
}

// ---------------------------------------------------------------------------------------------
// The energy account: stored, dissipated and the residual stacked, the work in as a line.

function energyPanel(root) {
  const need = ['energy.work', 'energy.kinetic', 'energy.potential', 'energy.dissipated'];
  if (!need.every(n => byName.has(n))) {
    root.append(el('p', { class: 'mb-note', text: 'No energy account in this run (energy.work, .kinetic, .potential, .dissipated).' }));
    return;
  }
  const [w, k, p, d] = need.map(col);
  const stored = new Float64Array(rows), sd = new Float64Array(rows), sdr = new Float64Array(rows);
  for (let i = 0; i < rows; ++i) {
    stored[i] = k[i] + p[i];
    sd[i] = stored[i] + d[i];
    sdr[i] = w[i];  // stored + dissipated + residual = work in
  }
  // Synthetic columns, appended so that plots and exports treat them like the others.
  const add = (name, unit, v) => { columns.push({ index: columns.length, name, unit, synthetic: true }); values.push(v); byName.set(name, columns.length - 1); return columns.length - 1; };
  const cs = add('energy: stored', 'J', stored), cd = add('energy: stored + dissipated', 'J', sd), cr = add('energy: + residual (= work in)', 'J', sdr);
  const container = el('div');
  root.append(container);
  addPlot({
    x: 0, ys: [cs, cd, cr], title: 'Energy account: stored, dissipated and residual stacked; their top is the work in', height: 240,
    bands: [{ series: [2, 1], fill: 'rgba(214,39,40,0.25)' }, { series: [3, 2], fill: 'rgba(127,127,127,0.35)' }],
    fills: ['rgba(31,119,180,0.3)', null, null],
  }, container);
}

// ---------------------------------------------------------------------------------------------
// The bond graph: Graphviz's drawing operations (xdot), drawn here as SVG with text nodes.

function graphPanel(root) {
  const g = raw.graph;
  if (!g || !Array.isArray(g.nodes)) {
    root.append(el('p', { class: 'mb-note', text: raw.graph_note || 'No bond graph: give the model with --model.' }));
    return;
  }
  const [W, H] = g.bb;
  const svg = svgEl('svg', { viewBox: `0 0 ${W} ${H}`, width: '100%', class: 'mb-graph', id: 'mb-graph' });
  svg.style.maxHeight = '70vh';
  const colorOk = c => (typeof c === 'string' && /^(#[0-9a-fA-F]{3,8}|[a-z]{1,20})$/.test(c) ? c : '#000000');
  const pts = p => p.map(([x, y]) => `${x},${H - y}`).join(' ');
  function draw(ops, parent) {
    let stroke = '#000000', fill = 'none', size = 12, dash = null;
    for (const o of ops) {
      let s = null;
      switch (o.op) {
        case 'c': stroke = colorOk(o.color); break;
        case 'C': fill = colorOk(o.color); break;
        case 'F': size = Number(o.size) || 12; break;
        case 'S': dash = o.style === 'dashed' ? '5,3' : o.style === 'dotted' ? '1,3' : null; break;
        case 'e': case 'E': {
          const [x, y, rx, ry] = o.rect;
          s = svgEl('ellipse', { cx: x, cy: H - y, rx, ry, fill: o.op === 'E' ? fill : 'none', stroke });
          break;
        }
        case 'p': case 'P': s = svgEl('polygon', { points: pts(o.points), fill: o.op === 'P' ? fill : 'none', stroke }); break;
        case 'L': s = svgEl('polyline', { points: pts(o.points), fill: 'none', stroke }); break;
        case 'b': case 'B': {
          const p = o.points;
          let dd = `M${p[0][0]},${H - p[0][1]}`;
          for (let i = 1; i + 2 < p.length; i += 3) {
            dd += ` C${p[i][0]},${H - p[i][1]} ${p[i + 1][0]},${H - p[i + 1][1]} ${p[i + 2][0]},${H - p[i + 2][1]}`;
          }
          s = svgEl('path', { d: dd, fill: o.op === 'B' ? fill : 'none', stroke });
          break;
        }
        case 'T': {
          s = svgEl('text', { x: o.pt[0], y: H - o.pt[1], 'font-size': size, 'font-family': 'Helvetica, Arial, sans-serif',
            'text-anchor': o.align === 'l' ? 'start' : o.align === 'r' ? 'end' : 'middle', fill: stroke });
          s.textContent = String(o.text);
          break;
        }
        default: break;
      }
      if (s) {
        if (dash) s.setAttribute('stroke-dasharray', dash);
        parent.append(s);
      }
    }
  }
  for (const c of g.clusters || []) { const grp = svgEl('g', { class: 'mb-cluster' }); draw(c.draw, grp); svg.append(grp); }
  for (const e of g.edges || []) { const grp = svgEl('g', { class: 'mb-edge' }); draw(e.draw, grp); svg.append(grp); }
  const nodeShapes = [];
  for (const n of g.nodes) {
    const grp = svgEl('g', { class: 'mb-node' });
    grp.dataset.element = n.element;
    const [x, y, w, h] = n.box;
    const box = svgEl('rect', { x: x - w / 2, y: H - y - h / 2, width: w, height: h, rx: 4, fill: '#ffffff', stroke: '#bbbbbb', class: 'mb-node-box' });
    const title = svgEl('title');
    title.textContent = `${n.element}: click to plot`;
    grp.append(title, box);
    draw(n.draw, grp);
    const cols = columns.filter(c => !c.synthetic && c.name.startsWith(`${n.element}.`)).map(c => c.index);
    if (cols.length) {
      grp.classList.add('mb-clickable');
      grp.addEventListener('click', () => plotGroup(cols, n.element));
    }
    // Power at the cursor: the rate of change of the element's energy, dissipation or work.
    // (a source's work is what it gives out: its power in is minus the rate of its work)
    const kind = ['energy', 'dissipated', 'work'].find(s => col(`${n.element}.${s}`));
    nodeShapes.push({ box, energy: kind ? col(`${n.element}.${kind}`) : null, sign: kind === 'work' ? -1 : 1 });
    svg.append(grp);
  }
  // Zoom (wheel) and pan (drag) by the view box.
  let view = [0, 0, W, H];
  const setView = v => { view = v; svg.setAttribute('viewBox', v.join(' ')); };
  svg.addEventListener('wheel', ev => {
    ev.preventDefault();
    const r = svg.getBoundingClientRect();
    const fx = (ev.clientX - r.left) / r.width, fy = (ev.clientY - r.top) / r.height;
    const k = ev.deltaY < 0 ? 0.8 : 1.25;
    const w = Math.min(W * 2, view[2] * k), h = Math.min(H * 2, view[3] * k);
    setView([view[0] + (view[2] - w) * fx, view[1] + (view[3] - h) * fy, w, h]);
  }, { passive: false });
  svg.addEventListener('mousedown', ev => {
    const r = svg.getBoundingClientRect(), x0 = ev.clientX, y0 = ev.clientY, v0 = view.slice();
    let moved = false;
    const move = e => {
      moved = moved || Math.abs(e.clientX - x0) + Math.abs(e.clientY - y0) > 3;
      setView([v0[0] - ((e.clientX - x0) * v0[2]) / r.width, v0[1] - ((e.clientY - y0) * v0[3]) / r.height, v0[2], v0[3]]);
    };
    const up = () => {
      window.removeEventListener('mousemove', move);
      window.removeEventListener('mouseup', up);
      if (moved) svg.addEventListener('click', e => e.stopPropagation(), { capture: true, once: true });
    };
    window.addEventListener('mousemove', move);
    window.addEventListener('mouseup', up);
  });
  svg.addEventListener('dblclick', () => setView([0, 0, W, H]));
  const key = el('p', { class: 'mb-note', text: 'Wheel to zoom, drag to pan, double-click to fit. Click an element to plot its columns (state, energy, ...). Fill: its power at the cursor\u2019s time (the rate of its energy or dissipation, minus that of a source\u2019s work): red takes power in, blue gives it out.' });
  root.append(svg, key);
  const maxPower = nodeShapes.map(s => {
    let m = 0;
    if (!s.energy) return 0;
    for (let i = 1; i < rows; ++i) { const dt = time[i] - time[i - 1]; if (dt > 0) m = Math.max(m, Math.abs((s.energy[i] - s.energy[i - 1]) / dt)); }
    return m;
  });
  timeListeners.push(r => {
    nodeShapes.forEach((s, k) => {
      if (!s.energy || !(maxPower[k] > 0)) return;
      const i = Math.max(1, r), dt = time[i] - time[i - 1];
      const pw = dt > 0 ? (s.sign * (s.energy[i] - s.energy[i - 1])) / dt : 0;
      const a = Math.min(1, Math.abs(pw) / maxPower[k]);
      s.box.setAttribute('fill', pw >= 0 ? `rgba(214,39,40,${(0.1 + 0.7 * a).toFixed(3)})` : `rgba(31,119,180,${(0.1 + 0.7 * a).toFixed(3)})`);
    });
  });
}

// ---------------------------------------------------------------------------------------------
// The 3D view.

let scene3d = null;
function sceneTransform(name, r) {
  const c = s => col(`${name}.${s}`);
  const x = c('r.x'), y = c('r.y'), z = c('r.z');
  const R = ['11', '12', '13', '21', '22', '23', '31', '32', '33'].map(k => c(`R.${k}`));
  if (!x || !y || !z) return null;
  const m = new THREE.Matrix4();
  const Rv = R.every(Boolean) ? R.map(a => a[r]) : [1, 0, 0, 0, 1, 0, 0, 0, 1];
  m.set(Rv[0], Rv[1], Rv[2], x[r], Rv[3], Rv[4], Rv[5], y[r], Rv[6], Rv[7], Rv[8], z[r], 0, 0, 0, 1);
  return m;
}

// A gear's outline in the x-y plane: n trapezoidal teeth from the root radius to the tip radius.
function toothedShape(root, tip, n) {
  const shape = new THREE.Shape();
  for (let k = 0; k < n; ++k) {
    const a0 = (2 * Math.PI * k) / n, da = (2 * Math.PI) / n;
    const pts = [[root, a0], [tip, a0 + da * 0.25], [tip, a0 + da * 0.5], [root, a0 + da * 0.75]];
    pts.forEach(([rr, a], i) => (k === 0 && i === 0 ? shape.moveTo(rr * Math.cos(a), rr * Math.sin(a)) : shape.lineTo(rr * Math.cos(a), rr * Math.sin(a))));
  }
  shape.closePath();
  return shape;
}

function gearGeometry(teeth, diameter, thickness, cone) {
  const R = diameter / 2, depth = Math.min(R * 0.12, (Math.PI * diameter) / teeth * 0.35);
  const n = Math.max(6, Math.min(400, Math.round(teeth)));
  const geo = new THREE.ExtrudeGeometry(toothedShape(R - depth, R, n), { depth: thickness, bevelEnabled: false });
  geo.translate(0, 0, -thickness / 2);
  if (cone) {
    // A bevel gear: the teeth taper towards the apex (scale x, y along z).
    const p = geo.attributes.position;
    for (let i = 0; i < p.count; ++i) { const s = 1 - 0.2 * (p.getZ(i) / thickness + 0.5); p.setX(i, p.getX(i) * s); p.setY(i, p.getY(i) * s); }
    geo.computeVertexNormals();
  }
  return geo;  // axis z
}

// A bevel gear on its pitch cone, about z: `apex` is the signed distance along z from the body's
// centre to the cone's apex (where the mesh's axes cross). The heel's pitch circle, radius
// R = diameter / 2, lies in the centre plane; towards the apex the gear tapers linearly over the
// face width F = min(L / 3, 10 m) (L = sqrt(R^2 + apex^2) the cone distance, m = diameter / teeth
// the module), so the toe's pitch radius is R (1 - f) at f apex along z, f = F / L. Every cross
// section is the toothed profile scaled by its distance to the apex, the teeth half above and half
// below the pitch cone along its normal: two gears in mesh share the apex, and their teeth overlap
// along the line where their cones touch. One extrusion, mapped once (no cost per frame).
function bevelGeometry(teeth, diameter, apex) {
  const R = diameter / 2, n = Math.max(6, Math.min(400, Math.round(teeth)));
  const depth = Math.min(R * 0.3, ((Math.PI * diameter) / n) * 0.35);
  // An apex (nearly) in the centre plane: a face gear; kept a tooth's depth away so the caps stay apart.
  const a = Math.max(Math.abs(apex), depth), L = Math.hypot(R, a);
  const f = Math.min(L / 3, (10 * diameter) / n) / L;
  const nr = a / L, nz = R / L;  // the pitch cone's outward normal, radial and axial
  const geo = new THREE.ExtrudeGeometry(toothedShape(R - depth / 2, R + depth / 2, n), { depth: 1, bevelEnabled: false });
  // (x, y, v), v from 0 (heel) to 1 (toe): the pitch point at s = 1 - f v of the heel's, moved by
  // the profile's height h above the pitch circle along the normal (the map keeps the faces' sense).
  const p = geo.attributes.position;
  for (let i = 0; i < p.count; ++i) {
    const x = p.getX(i), y = p.getY(i), v = p.getZ(i), rho = Math.hypot(x, y), h = rho - R, s = 1 - f * v;
    const q = (s * (R + h * nr)) / rho;
    p.setXYZ(i, x * q, y * q, f * v * a + s * h * nz);
  }
  if (apex < 0) geo.rotateX(Math.PI);  // the apex on -z (a turn, not a mirror: the faces stay outward)
  geo.computeVertexNormals();
  return geo;  // axis z
}

const finite = v => typeof v === 'number' && Number.isFinite(v);

function bodyMesh(b, color) {
  const s = b.shape || {};
  let geo, axis = typeof s.axis === 'number' ? s.axis : 2;
  let translucent = false;
  const gear = s.type === 'gear' && finite(s.teeth) && finite(s.diameter) && s.diameter > 0 && finite(s.length);
  if (gear && finite(s.apex)) geo = bevelGeometry(s.teeth, s.diameter, s.apex);
  else if (gear) geo = gearGeometry(s.teeth, s.diameter, Math.max(s.length, s.diameter * 0.05), s.cone);
  else if (s.type === 'cylinder') { geo = new THREE.CylinderGeometry(s.diameter / 2, s.diameter / 2, s.length, 48); geo.rotateX(Math.PI / 2); }
  else if (s.type === 'box') { geo = new THREE.BoxGeometry(s.size[0], s.size[1], s.size[2]); axis = 2; }
  else if (s.type === 'sphere') geo = new THREE.SphereGeometry(s.diameter / 2, 32, 16);
  else { geo = new THREE.BoxGeometry(...(s.size || [0.05, 0.05, 0.05])); translucent = true; axis = 2; }
  // Geometry built about z; turn it to the body axis.
  if (axis === 0) geo.rotateY(Math.PI / 2);
  else if (axis === 1) geo.rotateX(-Math.PI / 2);
  const mat = new THREE.MeshStandardMaterial({ color, metalness: 0.2, roughness: 0.6, transparent: translucent, opacity: translucent ? 0.15 : 1,
    depthWrite: !translucent });
  const mesh = new THREE.Mesh(geo, mat);
  if (!translucent) {
    // A stripe on the rim so that turning shows.
    const mark = new THREE.Mesh(new THREE.BoxGeometry(0.01, 0.01, 0.01), new THREE.MeshStandardMaterial({ color: 0x222222 }));
    const size = new THREE.Box3().setFromObject(mesh).getSize(new THREE.Vector3());
    const r = Math.max(size.x, size.y, size.z) / 2;
    mark.scale.set(r * 4, r * 4, r * 4);
    const dir = [new THREE.Vector3(0, 1, 0), new THREE.Vector3(0, 0, 1), new THREE.Vector3(1, 0, 0)][axis];
    mark.position.copy(dir.multiplyScalar(r * 0.8));
    mesh.add(mark);
  } else {
    mesh.add(new THREE.LineSegments(new THREE.EdgesGeometry(geo), new THREE.LineBasicMaterial({ color: 0x666666 })));
  }
  return mesh;
}

function scenePanel(root) {
  const sc = raw.scene;
  if (!sc || !Array.isArray(sc.bodies) || !sc.bodies.length) {
    root.append(el('p', { class: 'mb-note', text: raw.scene_note || 'No 3D view: this run has no bodies, or no model was given (--model).' }));
    return;
  }
  const bodies = sc.bodies.filter(b => col(`${b.name}.r.x`));
  if (!bodies.length) {
    root.append(el('p', { class: 'mb-note', text: 'No 3D view: results.csv has no body positions (B.r.x, .y, .z).' }));
    return;
  }
  const holder = el('div', { class: 'mb-3d', id: 'mb-3d' });
  const readout = el('table', { class: 'mb-readout', id: 'mb-readout' });
  const play = el('button', { type: 'button', text: '\u25b6 play', id: 'mb-play' });
  const speed = el('select', { 'aria-label': 'speed' });
  for (const s of ['0.01', '0.1', '0.25', '1', '4']) speed.append(el('option', { value: s, text: `${s}\u00d7` }));
  speed.value = '0.1';
  const forceScale = el('input', { type: 'range', min: '0', max: '100', value: '0', 'aria-label': 'force arrows', title: 'joint reaction force arrows: length per newton' });
  const frames = el('button', { type: 'button', text: 'PNG frames (zip)', title: 'render up to 300 frames over the run to PNGs and save them as a zip (ffmpeg -i frame-%04d.png makes a video of them)' });
  const video = el('button', { type: 'button', text: 'video (WebM)', title: 'record the run played at the chosen speed (the browser\u2019s own encoder)' });
  if (typeof MediaRecorder === 'undefined') video.disabled = true;
  holder.style.height = '480px';
  root.append(el('div', { class: 'mb-list-tools' }, play, el('label', { text: ' speed ' }), speed, el('label', { text: ' force arrows ' }), forceScale, frames, video),
    el('div', { class: 'mb-3d-row' }, holder, readout));

  const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(devicePixelRatio);
  renderer.setSize(holder.clientWidth || 800, 480);
  renderer.setClearColor(0xf4f6f8);
  holder.append(renderer.domElement);
  const scene = new THREE.Scene();
  scene.add(new THREE.AmbientLight(0xffffff, 0.6));
  const light = new THREE.DirectionalLight(0xffffff, 1.6);
  light.position.set(1, 2, 3);
  scene.add(light);
  const objects = new Map();
  const box = new THREE.Box3();
  bodies.forEach((b, k) => {
    const mesh = bodyMesh(b, PALETTE[k % PALETTE.length]);
    mesh.matrixAutoUpdate = false;
    mesh.name = b.name;
    scene.add(mesh);
    objects.set(b.name, mesh);
    mesh.matrix.copy(sceneTransform(b.name, 0));
    mesh.updateMatrixWorld(true);
    if (b.shape && b.shape.type !== 'inertia') box.expandByObject(mesh);
    else box.expandByPoint(new THREE.Vector3().setFromMatrixPosition(mesh.matrix));
  });
  const size = Math.max(box.getSize(new THREE.Vector3()).length(), 0.2);
  const center = box.getCenter(new THREE.Vector3());
  scene.add(new THREE.AxesHelper(size * 0.3));
  // Joints: a dot at each joint's point on its child; an arrow for its reaction force.
  const joints = (sc.joints || []).filter(j => objects.has(j.child)).map(j => {
    const dot = new THREE.Mesh(new THREE.SphereGeometry(size * 0.008, 12, 8), new THREE.MeshBasicMaterial({ color: 0x000000 }));
    scene.add(dot);
    const F = ['x', 'y', 'z'].map(a => col(`${j.name}.F.${a}`));
    const arrow = F.every(Boolean) ? new THREE.ArrowHelper(new THREE.Vector3(1, 0, 0), new THREE.Vector3(), 0.1, 0xcc3300) : null;
    if (arrow) { arrow.visible = false; scene.add(arrow); }
    return { j, dot, F, arrow };
  });
  // Paths of the points (e.g. a planet's rim point) as trails up to the current time.
  const trails = (sc.points || []).map(p => {
    const P = ['x', 'y', 'z'].map(a => col(`${p.name}.${a}`));
    if (!P.every(Boolean)) return null;
    const stride = Math.max(1, Math.ceil(rows / 4000)), n = Math.ceil(rows / stride);
    const pos = new Float32Array(n * 3);
    for (let i = 0, k = 0; i < rows; i += stride, ++k) { pos[3 * k] = P[0][i]; pos[3 * k + 1] = P[1][i]; pos[3 * k + 2] = P[2][i]; }
    const geo = new THREE.BufferGeometry();
    geo.setAttribute('position', new THREE.BufferAttribute(pos, 3));
    const line = new THREE.Line(geo, new THREE.LineBasicMaterial({ color: 0x9467bd }));
    scene.add(line);
    return { line, stride, n };
  }).filter(Boolean);
  const camera = new THREE.PerspectiveCamera(40, (holder.clientWidth || 800) / 480, size / 100, size * 100);
  camera.position.copy(center).add(new THREE.Vector3(size * 0.8, -size * 1.1, size * 0.8));
  camera.up.set(0, 0, 1);
  const controls = new OrbitControls(camera, renderer.domElement);
  controls.target.copy(center);
  controls.update();

  const readoutCols = [...(sc.drives || []).flatMap(d => [`${d.name}.torque`, `${d.name}.force`]), ...joints.map(x => x.j.name)]
    .filter(n => byName.has(n) || joints.some(x => x.j.name === n && x.arrow));
  function update(r) {
    for (const [name, mesh] of objects) { mesh.matrix.copy(sceneTransform(name, r)); mesh.matrixWorldNeedsUpdate = true; }
    const scale = Number(forceScale.value) * size * 0.002;
    for (const x of joints) {
      const child = objects.get(x.j.child).matrix;
      const p = new THREE.Vector3(...x.j.child_point).applyMatrix4(child);
      x.dot.position.copy(p);
      if (x.arrow) {
        const f = new THREE.Vector3(x.F[0][r], x.F[1][r], x.F[2][r]);
        const len = f.length() * scale;
        x.arrow.visible = len > 0;
        if (len > 0) { x.arrow.position.copy(p); x.arrow.setDirection(f.normalize()); x.arrow.setLength(len, Math.min(len * 0.3, size * 0.04), size * 0.02); }
      }
    }
    for (const t of trails) t.line.geometry.setDrawRange(0, Math.min(t.n, Math.floor(r / t.stride) + 1));
    readout.replaceChildren(el('tr', {}, el('th', { text: `t = ${fmtNum(time[r])} s` }), el('th', { text: 'value' })));
    for (const n of readoutCols) {
      if (byName.has(n)) readout.append(el('tr', {}, el('td', { text: n }), el('td', { text: `${fmtNum(col(n)[r])} ${columns[byName.get(n)].unit}` })));
      else {
        const x = joints.find(j => j.j.name === n);
        const f = Math.hypot(x.F[0][r], x.F[1][r], x.F[2][r]);
        readout.append(el('tr', {}, el('td', { text: `|${n}.F|` }), el('td', { text: `${fmtNum(f)} N` })));
      }
    }
    renderer.render(scene, camera);
  }
  controls.addEventListener('change', () => renderer.render(scene, camera));
  forceScale.addEventListener('input', () => update(currentRow));
  timeListeners.push(r => update(r));
  let playing = false, last = 0;
  play.addEventListener('click', () => {
    playing = !playing;
    play.textContent = playing ? '\u275a\u275a pause' : '\u25b6 play';
    last = performance.now();
    if (playing) requestAnimationFrame(step);
  });
  function step(now) {
    if (!playing) return;
    const t = time[currentRow] + ((now - last) / 1000) * Number(speed.value);
    last = now;
    const r = rowAt(t);
    setRow(r >= rows - 1 && t > time[rows - 1] ? 0 : Math.max(r, currentRow), null);
    requestAnimationFrame(step);
  }
  frames.addEventListener('click', async () => {
    const n = Math.min(300, rows), files = [];
    const saved = currentRow;
    for (let k = 0; k < n; ++k) {
      update(Math.round((k * (rows - 1)) / Math.max(1, n - 1)));
      const blob = await new Promise(res => renderer.domElement.toBlob(res, 'image/png'));
      files.push({ name: `frame-${String(k).padStart(4, '0')}.png`, data: new Uint8Array(await blob.arrayBuffer()) });
    }
    update(saved);
    download('frames.zip', zipStored(files));
  });
  video.addEventListener('click', async () => {
    const stream = renderer.domElement.captureStream(30);
    const rec = new MediaRecorder(stream, { mimeType: 'video/webm' });
    const chunks = [];
    rec.ondataavailable = e => chunks.push(e.data);
    const done = new Promise(res => { rec.onstop = res; });
    rec.start();
    const seconds = Math.min(60, (time[rows - 1] - time[0]) / Number(speed.value));
    const t0 = performance.now();
    await new Promise(res => {
      const frame = now => {
        const t = time[0] + ((now - t0) / 1000) * Number(speed.value);
        update(rowAt(t));
        if ((now - t0) / 1000 < seconds) requestAnimationFrame(frame); else res();
      };
      requestAnimationFrame(frame);
    });
    rec.stop();
    await done;
    update(currentRow);
    download('view.webm', new Blob(chunks, { type: 'video/webm' }));
  });
  scene3d = { objects, update, renderer };
  update(0);
  new ResizeObserver(() => {
    const w = holder.clientWidth;
    if (w > 0) { renderer.setSize(w, 480); camera.aspect = w / 480; camera.updateProjectionMatrix(); renderer.render(scene, camera); }
  }).observe(holder);
}

// ---------------------------------------------------------------------------------------------
// The page.

function section(id, title, parent) {
  const s = el('section', { id, class: 'mb-section' }, el('h2', { text: title }));
  parent.append(s);
  return s;
}

function main() {
  const app = document.getElementById('mb-app');
  app.replaceChildren();
  const layout = el('div', { class: 'mb-layout' });
  const side = el('aside', { class: 'mb-side' });
  const mainCol = el('div', { class: 'mb-main' });
  layout.append(side, mainCol);
  app.append(layout);

  const scrub = el('input', { type: 'range', min: '0', max: String(Math.max(0, rows - 1)), value: '0', id: 'mb-scrub', 'aria-label': 'time' });
  const tRead = el('span', { class: 'mb-time', id: 'mb-time' });
  scrub.addEventListener('input', () => setRow(Number(scrub.value), scrub));
  const evRead = el('span', { class: 'mb-note', id: 'mb-event-at' });
  timeListeners.push(r => {
    scrub.value = String(r);
    tRead.textContent = `t = ${fmtNum(time[r])} s`;
    // The last event at or before the cursor.
    let last = null;
    for (const e of events) { if (e.time <= time[r]) last = e; else break; }
    evRead.textContent = last ? `last event: ${last.kind} ${last.element} at ${fmtNum(last.time)} s: ${last.description}` : '';
  });
  const bar = el('div', { class: 'mb-bar' }, el('strong', { text: 'time ' }), scrub, tRead);
  if (events.length) bar.append(el('span', { class: 'mb-note', text: ` \u00b7 ${raw.event_count || events.length} events marked on the plots against time` }), evRead);
  mainCol.append(bar);

  side.append(el('h2', { text: 'Columns' }));
  buildColumnList(side);
  timings.list = performance.now();
  // A mechanism's page opens on its 3D view; the others have it (a note) at the end.
  const mechanism = raw.scene && Array.isArray(raw.scene.bodies) && raw.scene.bodies.length > 0;
  const s3 = section('mb-scene', '3D view', mechanism ? mainCol : document.createElement('div'));
  const eSec = section('mb-energy', 'Energy account', mainCol);
  const pSec = section('mb-plots-section', 'Plots', mainCol);
  if (mechanism) mainCol.insertBefore(pSec, eSec);
  energyPanel(eSec);
  timings.energy = performance.now();
  pSec.append(el('p', { class: 'mb-note', text: 'Click a column to plot it; tick several and "plot selected" for shared axes (against time or another column). Drag to zoom, wheel to zoom, shift-drag to pan, double-click to reset.' }));
  pSec.append(el('div', { id: 'mb-plots' }));
  if (!mechanism) mainCol.append(s3);
  scenePanel(s3);
  timings.scene = performance.now();
  const gSec = section('mb-graph-section', 'Bond graph', mainCol);
  graphPanel(gSec);
  timings.graph = performance.now();
  // A first plot: the model's named outputs, else the first column.
  const outputs = columns.filter(c => c.index > 0 && !c.synthetic && !c.name.includes('.')).map(c => c.index);
  if (outputs.length) plotGroup(outputs.slice(0, 12));
  setRow(0, null);
  window.addEventListener('resize', resizePlots);
  timings.ready = performance.now();
  document.body.dataset.ready = '1';
}

// For the tests and for scripting from the console.
window.multibondPage = {
  columns: () => columns.filter(c => !c.synthetic).map(c => ({ name: c.name, unit: c.unit })),
  rows: () => rows,
  timings: () => ({ ...timings }),
  setTime: t => { setRow(rowAt(t), null); return currentRow; },
  row: () => currentRow,
  plotCount: () => plots.length,
  plotColumns: names => addPlot({ x: 0, ys: names.map(n => byName.get(n)).filter(c => c !== undefined), height: 200 }).title,
  plotTitles: () => plots.map(p => p.title),
  xRanges: () => plots.map(p => [p.u.scales.x.min, p.u.scales.x.max]),
  eventLines: () => plots.filter(p => p.timeX).map(p => p.lines.eventLines),
  bodyMatrix: name => (scene3d && scene3d.objects.has(name) ? Array.from(scene3d.objects.get(name).matrix.elements) : null),
  // A body's drawn mesh's box in the scene at the cursor's time: [[xmin, ymin, zmin], [xmax, ymax, zmax]].
  bodyBox: name => {
    if (!scene3d || !scene3d.objects.has(name)) return null;
    const b = new THREE.Box3().setFromObject(scene3d.objects.get(name), true);
    return [b.min.toArray(), b.max.toArray()];
  },
  plotSvg: k => new XMLSerializer().serializeToString(plotSvg(plots[k])),
};

try {
  main();
} catch (e) {
  document.getElementById('mb-app').textContent = `The interactive page failed: ${e && e.message}`;
  throw e;
}
