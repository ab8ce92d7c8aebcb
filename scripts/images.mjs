// node scripts/images.mjs OUT_DIR PAGE.html...: one PNG per page (scripts/images says which).
// A page named *_touch.html is shown at the frame where a hand touches the head nearest 2.8 s
// (the middle of the built-in touch clip's head window).
import { readFileSync } from 'node:fs';
import { writeFile } from 'node:fs/promises';
import { basename, join } from 'node:path';
import { Browser, findChromium } from '../tests/viewer/browser.mjs';

const [outDir, ...pages] = process.argv.slice(2);
const chromium = findChromium();
if (!chromium) {
  console.error('scripts/images: chromium not found (scripts/deps installs it)');
  process.exit(2);
}

function headFrame(file) {
  const html = readFileSync(file, 'utf8');
  const data = JSON.parse(html.match(/<script id="ss-data" type="application\/json">([\s\S]*?)<\/script>/)[1]);
  const sph = data.spheres, clip = data.clips[0];
  const hand = (s) => sph.joint_names[sph.joint[s]].includes('Hand');
  const head = (s) => sph.parts[sph.part[s]] === 'head';
  let best = 0;
  clip.pairs.forEach((p, f) => {
    for (let i = 0; i + 1 < p.length; i += 2) {
      const touching = (hand(p[i]) && head(p[i + 1])) || (hand(p[i + 1]) && head(p[i]));
      if (touching && Math.abs(clip.time[f] - 2.8) < Math.abs(clip.time[best] - 2.8)) best = f;
    }
  });
  return `#clip=${encodeURIComponent(clip.name)}&frame=${best}`;
}

const browser = await Browser.launch(chromium, { width: 1200, height: 760 });
const messages = browser.collectConsole();
try {
  for (const page of pages) {
    const name = basename(page, '.html');
    const hash = name.endsWith('_touch') ? headFrame(page) : '';
    await browser.navigate(`file://${page}${hash}`);
    await browser.waitFor('document.getElementById("ss-state").dataset.ready === "1"', 60000);
    await browser.settle();
    const { png } = await browser.screenshot();
    const out = join(outDir, (name.endsWith('_touch') ? name.replace(/_touch$/, '_head') : name) + '.png');
    await writeFile(out, png);
    console.log(`wrote ${out} (${hash || 'bind pose'})`);
  }
} finally {
  await browser.close();
}
const errors = messages.filter((m) => m.level === 'error');
for (const m of errors) console.error(`console error: ${m.text}`);
process.exit(errors.length ? 1 : 0);
