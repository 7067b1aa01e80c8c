// The front end of lift_gl.notebook.Viewer (anywidget): shows the frames the kernel sends,
// sends back drags (orbit) and wheel clicks (zoom), and edits the integrator and spp.

function render({ model, el }) {
  el.classList.add("lift-gl-viewer");
  const image = document.createElement("img");
  image.className = "lift-gl-frame";
  image.draggable = false;
  image.alt = "lift-gl render";
  const controls = document.createElement("div");
  controls.className = "lift-gl-controls";
  const integrator = document.createElement("select");
  integrator.className = "lift-gl-integrator";
  const spp = document.createElement("input");
  spp.type = "number";
  spp.min = "1";
  spp.className = "lift-gl-spp";
  const info = document.createElement("span");
  info.className = "lift-gl-info";
  const status = document.createElement("div");
  status.className = "lift-gl-status";
  controls.append("integrator ", integrator, " spp ", spp, " ", info);
  el.append(image, controls, status);

  let url = null;
  function showFrame() {
    const bytes = model.get("frame");
    if (!bytes || bytes.byteLength === 0) return;
    const old = url;
    url = URL.createObjectURL(new Blob([bytes], { type: "image/jpeg" }));
    image.src = url;
    if (old) URL.revokeObjectURL(old);
    image.dataset.frames = String(model.get("frames"));
  }
  function showSize() {
    const s = model.get("scale");
    image.style.width = `${model.get("width") * s}px`;
    image.style.height = `${model.get("height") * s}px`;
  }
  function showMenu() {
    integrator.replaceChildren(...model.get("integrators").map((name) => {
      const option = document.createElement("option");
      option.value = option.textContent = name;
      return option;
    }));
    integrator.value = model.get("integrator");
  }
  function showInfo() {
    info.textContent = `${model.get("samples")} / ${model.get("spp")} spp`;
    image.dataset.samples = String(model.get("samples"));
  }
  function showStatus() {
    status.textContent = model.get("status");
  }

  // Drag: orbit about the target. The moves of one animation frame go out as one message.
  let last = null, dx = 0, dy = 0, queued = false;
  function flush() {
    queued = false;
    if (dx !== 0 || dy !== 0) model.send({ kind: "orbit", dx, dy });
    dx = dy = 0;
  }
  image.addEventListener("pointerdown", (e) => {
    last = [e.clientX, e.clientY];
    image.setPointerCapture(e.pointerId);
    e.preventDefault();
  });
  image.addEventListener("pointermove", (e) => {
    if (last === null) return;
    dx += e.clientX - last[0];
    dy += e.clientY - last[1];
    last = [e.clientX, e.clientY];
    if (!queued) {
      queued = true;
      requestAnimationFrame(flush);
    }
  });
  const release = (e) => {
    last = null;
    flush();
  };
  image.addEventListener("pointerup", release);
  image.addEventListener("pointercancel", release);
  image.addEventListener("wheel", (e) => {
    e.preventDefault();
    model.send({ kind: "zoom", amount: e.deltaY < 0 ? 1 : -1 });
  }, { passive: false });

  integrator.addEventListener("change", () => {
    model.set("integrator", integrator.value);
    model.save_changes();
  });
  spp.addEventListener("change", () => {
    const n = Math.max(1, Math.round(Number(spp.value) || 1));
    model.set("spp", n);
    model.save_changes();
  });

  model.on("change:frame", showFrame);
  model.on("change:width change:height change:scale", showSize);
  model.on("change:integrators change:integrator", showMenu);
  model.on("change:samples change:spp", showInfo);
  model.on("change:spp", () => { spp.value = String(model.get("spp")); });
  model.on("change:status", showStatus);
  spp.value = String(model.get("spp"));
  showSize();
  showMenu();
  showInfo();
  showStatus();
  showFrame();
  return () => { if (url) URL.revokeObjectURL(url); };
}

export default { render };
