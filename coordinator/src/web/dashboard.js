// farm's dashboard: refreshes the server-rendered fragments, draws a job's
// image and error map as they render, and sends the actions. No library,
// no network but the coordinator's own port.
"use strict";

async function post(url, body) {
  const r = await fetch(url, {
    method: "POST",
    headers: { "x-farm-csrf": "1", "content-type": "application/x-www-form-urlencoded" },
    body: body || "",
  });
  if (!r.ok) {
    const text = await r.text();
    alertBar(text || r.statusText);
  }
  await refreshFragments();
}

function alertBar(text) {
  let bar = document.getElementById("alert");
  if (!bar) {
    bar = document.createElement("p");
    bar.id = "alert";
    bar.className = "failure";
    document.querySelector("main").prepend(bar);
  }
  bar.textContent = text;
}

// Fetches a server-rendered fragment again; false if signed out.
async function refreshFragment(el) {
  try {
    const r = await fetch(el.dataset.fragment, { cache: "no-store" });
    if (r.status === 401) { location.href = "/signin"; return false; }
    if (r.ok) el.innerHTML = await r.text();
  } catch (e) { /* the coordinator restarts: try again at the next tick */ }
  return true;
}

async function refreshFragments() {
  for (const el of document.querySelectorAll("[data-fragment]")) {
    if (!(await refreshFragment(el))) return;
  }
}

// Each fragment refreshes on its own period (data-every, in ms): every two
// seconds, or every five for a job's facts, whose tiles count the live
// image keeps up to date in between. While a live image is being looked
// at, the facts come with a look instead (`facts=1`), so the coordinator
// is asked once for both.
function period(el) {
  return Number(el.dataset.every) || 2000;
}

function startFragments() {
  for (const el of document.querySelectorAll("[data-fragment]")) {
    setInterval(() => refreshFragment(el), period(el));
  }
}

// The job's tiles done, from the live image's answer, between refreshes.
function showMerged(done) {
  const bar = document.querySelector(".facts progress");
  if (!bar || !(done > bar.value)) return;
  bar.value = done;
  if (bar.nextSibling) bar.nextSibling.textContent = ` ${done}/${bar.max}`;
}

document.addEventListener("click", (ev) => {
  const b = ev.target.closest("[data-action]");
  if (!b) return;
  ev.preventDefault();
  b.disabled = true;
  post(b.dataset.action, b.dataset.body);
});

// Linear [0, 1] to an 8-bit sRGB code value, by a table of 4096 steps.
const SRGB = new Uint8Array(4097);
for (let i = 0; i <= 4096; i++) {
  const v = i / 4096;
  const s = v <= 0.0031308 ? 12.92 * v : 1.055 * Math.pow(v, 1 / 2.4) - 0.055;
  SRGB[i] = Math.floor(s * 255 + 0.5);
}
function srgb8(v) {
  if (!(v > 0)) return 0;
  return SRGB[Math.round(Math.min(v, 1) * 4096)];
}

// A relMSE estimate as a colour: log scale from 1e-5 (black) through
// purple, orange and yellow to 1 and above (white).
const HEAT = [[0, 0, 0], [0.34, 0.06, 0.43], [0.87, 0.32, 0.23], [0.99, 0.8, 0.15], [1, 1, 1]];
function heatColour(e) {
  if (!(e > 0) || !isFinite(e)) return [0, 0, 0, 255];
  const t = Math.min(Math.max((Math.log10(e) + 5) / 5, 0), 1) * (HEAT.length - 1);
  const i = Math.min(Math.floor(t), HEAT.length - 2);
  const k = t - i;
  const c = (j) => Math.round((HEAT[i][j] * (1 - k) + HEAT[i + 1][j] * k) * 255);
  return [c(0), c(1), c(2), 255];
}

// How long to wait before the next look, in ms, given the tiles merged a
// second since the last: a look per 64 new tiles, so a look's fixed cost
// stays small next to the work it shows, but at least one every 5 s and at
// most one every 2 s (as the coordinator paces tev, server/mod.rs).
function nextLook(rate) {
  return rate > 0 ? Math.min(5000, Math.max(2000, 64000 / rate)) : 5000;
}

// A job page's pictures: poll the pieces changed since the last look.
function startLive(box) {
  const image = document.getElementById("image");
  const error = document.getElementById("error");
  let from = 0;
  let merged = 0;
  let updates = 0;
  let lastLook = performance.now();
  let mergedAtLook = 0;
  const facts = document.querySelector("[data-fragment]");
  let factsAt = performance.now();
  async function look() {
    let wait = 5000;
    const withFacts = facts && performance.now() - factsAt >= period(facts);
    const ask = `${box.dataset.live}?from=${from}&merged=${merged}${withFacts ? "&facts=1" : ""}`;
    try {
      const r = await fetch(ask, { cache: "no-store" });
      if (r.status === 401) { location.href = "/signin"; return; }
      if (r.ok) wait = draw(new DataView(await r.arrayBuffer()), withFacts);
    } catch (e) { /* try again */ }
    if (wait === null) {
      // The job ended: its facts once more, then on their own period.
      await refreshFragments();
      startFragments();
      return;
    }
    setTimeout(look, wait);
  }
  // Returns how long to wait before the next look (null: stop looking; 0:
  // the answer was a part and more is ready). The answer's layout is documented in
  // the coordinator's web/live.rs: pieces of the film's sums, which the
  // page resolves and tone-maps itself, and of the error map; then the
  // job's facts, if asked for.
  function draw(d, withFacts) {
    const u = (i) => d.getUint32(i, true);
    const f = (i) => d.getFloat32(i, true);
    const [w, h, next, done, state, scale, n] = [u(0), u(4), u(8), u(12), u(16), f(20), u(24)];
    if (state === 2) return null;
    if (w > 0 && (image.width !== w || image.height !== h)) {
      for (const c of [image, error]) { c.width = w; c.height = h; }
    }
    let at = 28;
    for (let k = 0; k < n; k++) {
      const [x, y, pw, ph, kind] = [u(at), u(at + 4), u(at + 8), u(at + 12), u(at + 16)];
      at += 20;
      const count = pw * ph;
      const px = new Uint8ClampedArray(kind === 2 ? 0 : count * 4);
      if (kind === 2) {
        // The error map only.
      } else if (state === 1) {
        // The finished image: its pixel values.
        for (let i = 0; i < count; i++, at += 12) {
          for (let c = 0; c < 3; c++) px[4 * i + c] = srgb8(f(at + 4 * c));
          px[4 * i + 3] = 255;
        }
      } else {
        // The film's sums as they stand.
        for (let i = 0; i < count; i++, at += 16) {
          const wt = f(at + 12);
          const inv = wt !== 0 ? 1 / wt : 1;
          for (let c = 0; c < 3; c++) {
            let v = f(at + 4 * c);
            if (wt !== 0) v = Math.max(v * inv, 0);
            px[4 * i + c] = srgb8(v * scale);
          }
          px[4 * i + 3] = 255;
        }
      }
      if (kind !== 2) image.getContext("2d").putImageData(new ImageData(px, pw, ph), x, y);
      if (kind !== 0) {
        const heat = new Uint8ClampedArray(count * 4);
        for (let i = 0; i < count; i++, at += 4) {
          heat.set(heatColour(f(at)), 4 * i);
        }
        error.getContext("2d").putImageData(new ImageData(heat, pw, ph), x, y);
      }
    }
    if (withFacts && at + 4 <= d.byteLength) {
      const len = u(at);
      facts.innerHTML = new TextDecoder().decode(new Uint8Array(d.buffer, d.byteOffset + at + 4, len));
      factsAt = performance.now();
    }
    if (n > 0) image.dataset.updates = String(++updates);
    from = next;
    merged = done;
    showMerged(done);
    if (state === 1) { image.dataset.done = "1"; return null; }
    if (state === 3) return 0;
    // The pace: tiles merged a second since the last whole look.
    const now = performance.now();
    const rate = (done - mergedAtLook) / Math.max((now - lastLook) / 1000, 0.001);
    [lastLook, mergedAtLook] = [now, done];
    return nextLook(rate);
  }
  look();
}

window.addEventListener("DOMContentLoaded", () => {
  const box = document.querySelector("[data-live]");
  if (box) {
    startLive(box);
  } else {
    startFragments();
  }
});
