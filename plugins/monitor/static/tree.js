// The behaviour tree as an SVG graph: left to right, one row per visible leaf, each parent
// centred on its children; status colours, the running path, collapsible subtrees,
// hover for details, click to pin them, wheel to zoom, drag to pan.

const SVG = "http://www.w3.org/2000/svg";
const W = 210, H = 46, COL = 250, ROW = 58;
const ICONS = {
  sequence: "→", selector: "?", parallel: "⇉", subtree: "⊂",
  composite: "▤", decorator: "◇", leaf: "●",
};
const STATUS_NAMES = { R: "RUNNING", S: "SUCCESS", F: "FAILURE", I: "INVALID" };

function el(name, attrs = {}, parent = null) {
  const node = document.createElementNS(SVG, name);
  for (const [k, v] of Object.entries(attrs)) node.setAttribute(k, v);
  if (parent) parent.appendChild(node);
  return node;
}

function escapeHtml(text) {
  return String(text).replace(/[&<>"']/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" })[c]);
}

function shown(value) {
  const text = typeof value === "string" ? value : JSON.stringify(value);
  return text.length > 160 ? text.slice(0, 157) + "…" : text;
}

function iconOf(node) {
  const type = (node.type || "").toLowerCase();
  for (const key of ["sequence", "selector", "parallel", "subtree"]) if (type.includes(key)) return ICONS[key];
  if (node.kind === "decorator") return ICONS.decorator;
  if (node.kind === "composite") return ICONS.composite;
  return ICONS.leaf;
}

function fitText(text, max) {
  return text.length > max ? text.slice(0, max - 1) + "…" : text;
}

export function nodeDetails(node, status, feedback) {
  const where = node.file ? `${node.file}:${node.line}:${node.column}` : "built inside its parent";
  const params = Object.entries(node.params || {});
  const rows = params.map(([k, v]) => `<tr><td>${escapeHtml(k)}</td><td>${escapeHtml(shown(v))}</td></tr>`).join("");
  return `
    <div class="tip-title">${escapeHtml(node.name)} <span class="pill s-${status}">${STATUS_NAMES[status]}</span></div>
    <div class="tip-type">${escapeHtml(node.type)}${node.class && node.class !== node.type ? " · " + escapeHtml(node.class) : ""}</div>
    <div class="tip-where">${escapeHtml(where)}</div>
    ${node.doc ? `<div class="tip-type">${escapeHtml(node.doc)}</div>` : ""}
    ${feedback ? `<div class="tip-feedback">${escapeHtml(feedback)}</div>` : ""}
    ${rows ? `<table class="params">${rows}</table>` : ""}`;
}

export class TreeView {
  constructor(svg, tooltip, onSelect) {
    this.svg = svg;
    this.tooltip = tooltip;
    this.onSelect = onSelect;
    this.nodes = [];
    this.letters = "";
    this.feedback = {};
    this.collapsed = new Set();
    this.selected = null;
    this.view = { x: 20, y: 20, k: 1 };
    this.viewport = el("g", {}, svg);
    this.edgeLayer = el("g", {}, this.viewport);
    this.nodeLayer = el("g", {}, this.viewport);
    this.elements = [];
    this.edges = [];
    this.fitted = false;
    this._interact();
  }

  setTree(tree) {
    this.nodes = tree.nodes;
    this.letters = "I".repeat(this.nodes.length);
    this.feedback = {};
    this.collapsed = new Set();
    this.selected = null;
    // Big trees open with deep subtrees folded, so the first view fits.
    if (this.nodes.length > 60) {
      for (const n of this.nodes) if (n.children.length && this._depth(n) >= 3) this.collapsed.add(n.id);
    }
    this._build();
    this.layout();
    this.fitted = false;
  }

  _depth(node) {
    let d = 0;
    for (let p = node.parent; p !== null && p !== undefined; p = this.nodes[p].parent) d++;
    return d;
  }

  _build() {
    this.edgeLayer.replaceChildren();
    this.nodeLayer.replaceChildren();
    this.elements = this.nodes.map((node) => {
      const g = el("g", { class: "node s-I", "data-id": node.id, "data-path": node.path }, this.nodeLayer);
      el("rect", { class: "box", width: W, height: H, rx: 8 }, g);
      el("rect", { class: "stripe", width: 5, height: H - 8, x: 3, y: 4, rx: 2 }, g);
      const icon = el("text", { class: "icon", x: 16, y: 20 }, g);
      icon.textContent = iconOf(node);
      const name = el("text", { class: "name", x: 32, y: 20 }, g);
      name.textContent = fitText(node.name, 24);
      const sub = el("text", { class: "sub", x: 32, y: 37 }, g);
      sub.textContent = fitText(node.type, 30);
      const entry = { g, sub, toggle: null, count: null };
      if (node.children.length) {
        const toggle = el("g", { class: "toggle", transform: `translate(${W + 12},${H / 2})` }, g);
        el("circle", { r: 9 }, toggle);
        const t = el("text", { y: 4 }, toggle);
        t.textContent = "−";
        toggle.addEventListener("click", (e) => { e.stopPropagation(); this.toggle(node.id); });
        entry.toggle = t;
        entry.count = el("text", { class: "hidden-count", x: W + 26, y: H / 2 + 4 }, g);
      }
      g.addEventListener("mouseenter", (e) => this._showTip(node, e));
      g.addEventListener("mousemove", (e) => this._moveTip(e));
      g.addEventListener("mouseleave", () => { this.tooltip.hidden = true; });
      g.addEventListener("click", () => this.select(node.id));
      g.addEventListener("dblclick", (e) => { e.stopPropagation(); if (node.children.length) this.toggle(node.id); });
      return entry;
    });
    this.edges = this.nodes.map((node) => node.parent === null || node.parent === undefined
      ? null : el("path", { class: "edge" }, this.edgeLayer));
  }

  toggle(id) {
    if (this.collapsed.has(id)) this.collapsed.delete(id); else this.collapsed.add(id);
    this.layout();
  }

  expandAll() {
    this.collapsed.clear();
    this.layout();
    this.fit();
  }

  _hiddenCount(id) {
    let count = 0;
    const stack = [...this.nodes[id].children];
    while (stack.length) { const c = stack.pop(); count++; stack.push(...this.nodes[c].children); }
    return count;
  }

  layout() {
    if (!this.nodes.length) return;
    const pos = new Array(this.nodes.length).fill(null);
    let row = 0;
    const place = (id, depth) => {
      const node = this.nodes[id];
      const open = node.children.length && !this.collapsed.has(id);
      let y;
      if (open) {
        const ys = node.children.map((c) => place(c, depth + 1));
        y = (ys[0] + ys[ys.length - 1]) / 2;
      } else {
        y = row * ROW;
        row += 1;
      }
      pos[id] = { x: depth * COL, y };
      return y;
    };
    this.root = this.nodes.findIndex((n) => n.parent === null || n.parent === undefined);
    place(this.root, 0);
    this.pos = pos;
    this.nodes.forEach((node, i) => {
      const entry = this.elements[i];
      const p = pos[i];
      entry.g.style.display = p ? "" : "none";
      if (p) entry.g.setAttribute("transform", `translate(${p.x},${p.y})`);
      if (entry.toggle) {
        const closed = this.collapsed.has(i);
        entry.toggle.textContent = closed ? "+" : "−";
        entry.count.textContent = closed ? `${this._hiddenCount(i)} hidden` : "";
        entry.count.setAttribute("x", W + 26);
      }
      const edge = this.edges[i];
      if (edge) {
        const pp = pos[node.parent];
        if (p && pp) {
          const x1 = pp.x + W, y1 = pp.y + H / 2, x2 = p.x, y2 = p.y + H / 2, mx = (x1 + x2) / 2 + 10;
          edge.setAttribute("d", `M${x1},${y1} C${mx},${y1} ${mx},${y2} ${x2},${y2}`);
          edge.style.display = "";
        } else {
          edge.style.display = "none";
        }
      }
    });
    this.size = { w: Math.max(...pos.filter(Boolean).map((p) => p.x)) + W + 80, h: row * ROW };
    this._applyStatuses(null);
  }

  setStatuses(letters, feedback) {
    const previous = this.letters;
    this.letters = letters;
    if (feedback) Object.assign(this.feedback, feedback);
    this._applyStatuses(previous);
  }

  _applyStatuses(previous) {
    const letters = this.letters;
    this.nodes.forEach((node, i) => {
      const c = letters[i] || "I";
      const entry = this.elements[i];
      if (!entry) return;
      const running = c === "R";
      const tip = running && !node.children.some((k) => letters[k] === "R");
      let cls = `node s-${c}`;
      if (tip) cls += " tip";
      if (this.selected === i) cls += " selected";
      if (previous && previous[i] !== c) cls += " changed";
      if (entry.g.getAttribute("class") !== cls) entry.g.setAttribute("class", cls);
      const fb = this.feedback[i];
      const subText = fitText(running && fb ? fb : node.type, 30);
      if (entry.sub.textContent !== subText) entry.sub.textContent = subText;
      const edge = this.edges[i];
      if (edge) {
        const active = running && letters[node.parent] === "R";
        edge.setAttribute("class", active ? "edge active" : "edge");
      }
    });
    if (this.selected !== null && this.onSelect) this.onSelect(this.selected, true);
  }

  select(id) {
    this.selected = this.selected === id ? null : id;
    this._applyStatuses(null);
    if (this.onSelect) this.onSelect(this.selected, false);
  }

  details(id) {
    return nodeDetails(this.nodes[id], this.letters[id] || "I", this.feedback[id]);
  }

  _showTip(node, event) {
    this.tooltip.innerHTML = this.details(node.id);
    this.tooltip.hidden = false;
    this._moveTip(event);
  }

  _moveTip(event) {
    const box = this.svg.getBoundingClientRect();
    const tip = this.tooltip;
    let x = event.clientX - box.left + 16, y = event.clientY - box.top + 16;
    if (x + tip.offsetWidth > box.width) x = Math.max(0, x - tip.offsetWidth - 32);
    if (y + tip.offsetHeight > box.height) y = Math.max(0, y - tip.offsetHeight - 32);
    tip.style.left = `${x}px`;
    tip.style.top = `${y}px`;
  }

  fit() {
    const box = this.svg.getBoundingClientRect();
    if (!this.size || box.width < 10) return;
    const k = Math.max(0.2, Math.min(1.5, (box.width - 40) / this.size.w, (box.height - 40) / Math.max(this.size.h, ROW)));
    this.view = {
      k,
      x: Math.max(20, (box.width - this.size.w * k) / 2),
      y: Math.max(20, (box.height - this.size.h * k) / 2),
    };
    this._applyView();
    this.fitted = true;
  }

  _applyView() {
    const { x, y, k } = this.view;
    this.viewport.setAttribute("transform", `translate(${x},${y}) scale(${k})`);
  }

  _interact() {
    let drag = null;
    this.svg.addEventListener("mousedown", (e) => {
      if (e.target.closest(".node")) return;
      drag = { x: e.clientX, y: e.clientY, vx: this.view.x, vy: this.view.y };
      this.svg.classList.add("dragging");
    });
    window.addEventListener("mousemove", (e) => {
      if (!drag) return;
      this.view.x = drag.vx + e.clientX - drag.x;
      this.view.y = drag.vy + e.clientY - drag.y;
      this._applyView();
    });
    window.addEventListener("mouseup", () => { drag = null; this.svg.classList.remove("dragging"); });
    this.svg.addEventListener("wheel", (e) => {
      e.preventDefault();
      const box = this.svg.getBoundingClientRect();
      const mx = e.clientX - box.left, my = e.clientY - box.top;
      const k = Math.min(3, Math.max(0.15, this.view.k * Math.exp(-e.deltaY * 0.0015)));
      this.view.x = mx - (mx - this.view.x) * (k / this.view.k);
      this.view.y = my - (my - this.view.y) * (k / this.view.k);
      this.view.k = k;
      this._applyView();
    }, { passive: false });
  }
}
