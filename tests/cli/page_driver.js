// SPDX-License-Identifier: MIT
// Drives the `watch --serve` page in headless chromium as a person would, for
// tests/cli/test_serve_page.c: node page_driver.js URL STEPS PROFILE. Chromium runs with the
// DevTools protocol on a pipe (--remote-debugging-pipe: file descriptors 3 and 4, messages ended
// by NUL), so no port is opened and nothing but chromium and Node.js is needed. The page is
// opened at URL; STEPS is a file of steps separated by lines "----", each the body of an async
// function run in the page (it can use until(fn, what[, limitMs]): wait until fn() is true, up to
// 60 s of real time or limitMs). Each step's value is printed as one line of JSON; a step that throws prints
// "error: ..." and ends the run with status 1. Chromium uses SwiftShader for WebGL2.
'use strict';
const { spawn } = require('child_process');
const fs = require('fs');

const [url, stepsFile, profile] = process.argv.slice(2);
if (!url || !stepsFile || !profile) {
  console.error('usage: node page_driver.js URL STEPS PROFILE');
  process.exit(2);
}
const steps = fs.readFileSync(stepsFile, 'utf8').split(/^----$/m).map(s => s.trim()).filter(Boolean);

const chrome = spawn('chromium', ['--headless=new', '--no-sandbox', '--use-angle=swiftshader',
  '--enable-unsafe-swiftshader', '--remote-debugging-pipe', '--user-data-dir=' + profile,
  '--window-size=1200,900', 'about:blank'], { stdio: ['ignore', 'ignore', 'ignore', 'pipe', 'pipe'] });
const toChrome = chrome.stdio[3], fromChrome = chrome.stdio[4];
let next = 0, buf = Buffer.alloc(0);
const waiting = new Map();
fromChrome.on('data', d => {
  buf = Buffer.concat([buf, d]);
  for (let k; (k = buf.indexOf(0)) >= 0;) {
    const msg = JSON.parse(buf.subarray(0, k).toString());
    buf = buf.subarray(k + 1);
    if (msg.id !== undefined && waiting.has(msg.id)) {
      waiting.get(msg.id)(msg);
      waiting.delete(msg.id);
    }
  }
});
function call(method, params, sessionId) {
  return new Promise((resolve, reject) => {
    const m = { id: ++next, method, params: params || {} };
    if (sessionId) m.sessionId = sessionId;
    waiting.set(m.id, msg => msg.error ? reject(new Error(method + ': ' + msg.error.message)) : resolve(msg.result));
    toChrome.write(JSON.stringify(m) + '\0');
  });
}

const helpers = `
async function until(fn, what, limitMs = 60000) {
  const t0 = Date.now();
  for (;;) {
    if (await fn()) return true;
    if (Date.now() - t0 > limitMs) throw new Error('timed out waiting for ' + (what || fn));
    await new Promise(r => setTimeout(r, 50));
  }
}`;

async function main() {
  const { targetId } = await call('Target.createTarget', { url: 'about:blank' });
  const { sessionId } = await call('Target.attachToTarget', { targetId, flatten: true });
  await call('Page.enable', {}, sessionId);
  await call('Page.navigate', { url }, sessionId);
  let status = 0;
  for (const step of steps) {
    const r = await call('Runtime.evaluate', {
      expression: `(async () => { ${helpers}\n${step}\n})()`, awaitPromise: true,
      returnByValue: true,
    }, sessionId);
    if (r.exceptionDetails) {
      const e = r.exceptionDetails;
      console.log('error: ' + (e.exception && e.exception.description || e.text));
      status = 1;
      break;
    }
    console.log(JSON.stringify(r.result.value === undefined ? null : r.result.value));
  }
  await call('Browser.close').catch(() => {});
  return status;
}

const limit = setTimeout(() => {
  console.log('error: the page driver ran out of time (300 s)');
  chrome.kill('SIGKILL');
  process.exit(1);
}, 300000);
main().then(status => {
  clearTimeout(limit);
  chrome.kill();
  process.exit(status);
}, e => {
  console.log('error: ' + e.message);
  chrome.kill('SIGKILL');
  process.exit(1);
});
