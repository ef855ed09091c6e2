// @ts-check
// The 2D view's legend: what each colour and mark means (palette.js's LEGEND, the colours the
// views draw with). Click its title to fold it.
import { LEGEND } from "./palette.js";
import { STATE_COLOURS } from "./palette.js";

export class Legend {
  /** @param {HTMLElement} el */
  constructor(el) {
    this.el = el;
    const rows = LEGEND.map(([colour, mark, means]) => `<li><i class="mark ${mark}" style="--c:${colour}"></i>${means}</li>`).join("");
    el.innerHTML = `<b class="legend-title" title="fold or unfold">legend</b><ul>${rows}</ul>`;
    const title = /** @type {HTMLElement} */ (el.querySelector(".legend-title"));
    title.onclick = () => el.classList.toggle("folded");
  }
}

export { STATE_COLOURS };
