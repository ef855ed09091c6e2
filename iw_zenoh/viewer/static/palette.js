// @ts-check
// What each colour means, in one place: the 2D view, the 3D view and the legend read these, so a
// colour and its explanation cannot drift apart.

/** A robot's state, by the one letter a frame carries (PageFrame.state) and by its name. */
export const STATE_NAMES = /** @type {const} */ ({ d: "driving", h: "held", w: "watchdog", c: "collided" });

/** @typedef {"driving" | "held" | "watchdog" | "collided"} RobotState */

/** @type {Record<RobotState, string>} */
export const STATE_COLOURS = { driving: "#2e9e44", held: "#e0a000", watchdog: "#9c4dcc", collided: "#e53935" };

/** @type {Record<RobotState, string>} */
export const STATE_MEANS = {
  driving: "driving (its agent's commands are applied)",
  held: "held: the world holds every robot (no collision verdict)",
  watchdog: "stopped by the watchdog (no actions for 500 ms)",
  collided: "collided",
};

export const COLOUR = {
  door: "#8d6e63",
  wall: "#8c8c96",
  obstacle: "#a1887f",
  obstacleSelected: "#ff7043",
  beacon: "#ffd54f",
  target: "#4fc3f7",
  scan: "#ff4081",     // where a laser beam hit
  cone: "#ff9800",     // a proximity cone up to what it reads
  trail: "#78aaff",
  collision: "#ff1744",
  incident: "#ffea00",
  nearMiss: "#fb8c00",
};

/**
 * The legend's rows: [colour, what it is drawn as ("box", "dot", "ring", "line"), what it means].
 * @type {[string, string, string][]}
 */
export const LEGEND = [
  ...(/** @type {RobotState[]} */ (Object.keys(STATE_COLOURS))).map((k) => /** @type {[string, string, string]} */ ([STATE_COLOURS[k], "box", `chair ${STATE_MEANS[k]}`])),
  [COLOUR.door, "box", "door"],
  [COLOUR.wall, "box", "wall (lighter: taller)"],
  [COLOUR.obstacle, "box", "obstacle (click to select, drag to move)"],
  [COLOUR.target, "ring", "target"],
  [COLOUR.beacon, "dot", "beacon"],
  [COLOUR.cone, "cone", "proximity cone, up to what it reads"],
  [COLOUR.scan, "dot", "laser hit"],
  [COLOUR.trail, "line", "trail"],
  ["#ffffff", "line", "heading (white line from the centre)"],
  [COLOUR.collision, "ring", "collision (flashes)"],
  [COLOUR.incident, "ring", "watchdog stop, removal, lost agent (flashes)"],
];

/** "#rrggbb" to [r, g, b] in 0..1 (WebGL's colours) */
export function rgb(/** @type {string} */ hex) {
  return [1, 3, 5].map((i) => parseInt(hex.slice(i, i + 2), 16) / 255);
}
