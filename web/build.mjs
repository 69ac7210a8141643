// Bundles the results page's script and style (src/page.js with uPlot and three.js) into
// OUTDIR/multibond-page.js and OUTDIR/multibond-page.css, which `multibond plot` copies next to
// each index.html. Usage: node build.mjs OUTDIR (run by CMake; the library files come from
// node_modules, installed by `npm ci`, never from the network at run time).
import { build } from 'esbuild';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const outdir = path.resolve(process.argv[2] || path.join(here, 'dist'));
await build({
  entryPoints: { 'multibond-page': path.join(here, 'src', 'page.js') },
  bundle: true,
  minify: true,
  format: 'iife',
  target: ['chrome100', 'firefox100', 'safari15'],
  legalComments: 'eof',
  outdir,
  logLevel: 'warning',
});
