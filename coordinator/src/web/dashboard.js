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

async function refreshFragments() {
  for (const el of document.querySelectorAll("[data-fragment]")) {
    try {
      const r = await fetch(el.dataset.fragment, { cache: "no-store" });
      if (r.status === 401) { location.href = "/signin"; return; }
      if (r.ok) el.innerHTML = await r.text();
    } catch (e) { /* the coordinator restarts: try again at the next tick */ }
  }
}

document.addEventListener("click", (ev) => {
  const b = ev.target.closest("[data-action]");
  if (!b) return;
  ev.preventDefault();
  b.disabled = true;
  post(b.dataset.action, b.dataset.body);
});

// A job page's pictures: poll the pieces changed since the last look.
function startLive(box) {
  const image = document.getElementById("image");
  const error = document.getElementById("error");
  let from = 0;
  let updates = 0;
  async function look() {
    let again = true;
    try {
      const r = await fetch(`${box.dataset.live}?from=${from}`, { cache: "no-store" });
      if (r.ok) again = draw(new DataView(await r.arrayBuffer()));
    } catch (e) { /* try again */ }
    if (again) setTimeout(look, 1000);
  }
  // Returns whether to keep looking.
  function draw(d) {
    const u = (i) => d.getUint32(i, true);
    const [w, h, next, state, n] = [u(0), u(4), u(8), u(12), u(16)];
    if (state === 2) return false;
    if (w > 0 && (image.width !== w || image.height !== h)) {
      for (const c of [image, error]) { c.width = w; c.height = h; }
    }
    let at = 20;
    for (let k = 0; k < n; k++) {
      const [x, y, pw, ph, hasError] = [u(at), u(at + 4), u(at + 8), u(at + 12), u(at + 16)];
      at += 20;
      const size = pw * ph * 4;
      const put = (canvas) => {
        const px = new Uint8ClampedArray(d.buffer, d.byteOffset + at, size);
        canvas.getContext("2d").putImageData(new ImageData(px, pw, ph), x, y);
        at += size;
      };
      put(image);
      if (hasError) put(error);
    }
    if (n > 0) image.dataset.updates = String(++updates);
    from = next;
    if (state === 1) { image.dataset.done = "1"; return false; }
    return true;
  }
  look();
}

window.addEventListener("DOMContentLoaded", () => {
  setInterval(refreshFragments, 2000);
  const box = document.querySelector("[data-live]");
  if (box) startLive(box);
});
