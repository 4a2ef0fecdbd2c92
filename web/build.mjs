// Bundles the page's script (src/app.js with three.js) into dist/app.js,
// the file the tandem binary embeds; `node build.mjs OTHER.js` writes
// elsewhere (the test script checks the committed bundle that way).
import { build } from 'esbuild';

await build({
  entryPoints: ['src/app.js'],
  bundle: true,
  minify: true,
  format: 'esm',
  target: 'es2020',
  legalComments: 'eof',
  outfile: process.argv[2] ?? 'dist/app.js',
  logLevel: 'error',
});
