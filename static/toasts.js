// Toasts of the front page: short messages at the top right of the 3D view that go away by themselves
// (the session's notices, the REST API's refusals, what a button did). Hovering a toast keeps it.
"use strict";

const Toasts = (() => {
  const MOST = 5;  // more at once would cover the scene: the oldest goes
  const LEVELS = ["info", "success", "warning", "error"];

  function box() {
    let element = document.getElementById("toasts");
    if (!element) {
      element = document.createElement("div");
      element.id = "toasts";
      document.body.append(element);
    }
    return element;
  }

  /** Show `text` ("info", "success", "warning" or "error") for `ms` milliseconds; returns the element. */
  function show(text, level = "info", ms = null) {
    const kind = LEVELS.includes(level) ? level : "info";
    const toast = document.createElement("div");
    toast.className = `toast toast-${kind}`;
    toast.setAttribute("role", kind === "error" || kind === "warning" ? "alert" : "status");
    const body = document.createElement("div");
    body.className = "toast-text";
    body.textContent = text;
    const close = document.createElement("button");
    close.type = "button";
    close.className = "toast-close";
    close.setAttribute("aria-label", "dismiss");
    close.textContent = "×";
    close.addEventListener("click", () => toast.remove());
    toast.append(body, close);
    const container = box();
    container.append(toast);
    while (container.children.length > MOST) container.firstElementChild.remove();
    const lifetime = ms ?? (kind === "error" ? 8000 : 5000);
    let timer = setTimeout(() => toast.remove(), lifetime);
    toast.addEventListener("mouseenter", () => clearTimeout(timer));
    toast.addEventListener("mouseleave", () => { timer = setTimeout(() => toast.remove(), 2000); });
    return toast;
  }

  return { show };
})();
