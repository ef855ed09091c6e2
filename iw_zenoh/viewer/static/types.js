// @ts-check
// The WebSocket's messages as JSDoc types, one per msgspec Struct of iw_zenoh/messages/page.py
// (docs/viewer.md draws the exchange). Types only: nothing here runs. The other modules import
// them with `import("./types.js").Name`; tests/viewer/test_page_types.py keeps the two in step.

/** @typedef {[number, number]} Xy */

/**
 * @typedef {object} PageHello  first message on a connection
 * @property {"hello"} type
 * @property {boolean} live
 * @property {string} sim
 * @property {string} version
 * @property {boolean} steer  false: this page may only watch
 */

/**
 * @typedef {object} PageSensor  a proximity cone in the robot's frame
 * @property {number} id
 * @property {number} x  m
 * @property {number} y  m
 * @property {number} angle_deg
 * @property {number} cone_deg
 * @property {number} range_m
 */

/**
 * @typedef {object} PageLaser  a laser scanner; beam k looks angle - fov/2 + k fov / (beams - 1)
 * @property {number} id
 * @property {number} x  m
 * @property {number} y  m
 * @property {number} angle_deg
 * @property {number} fov_deg
 * @property {number} beams
 * @property {number} range_m
 */

/**
 * @typedef {object} PageRobot  a robot as drawn
 * @property {number} id
 * @property {string} name
 * @property {string} type  "Simulated", "Real" or "Door"
 * @property {Xy[]} outline  in its own frame (origin: centre of movement, x along the heading)
 * @property {PageSensor[]} sensors
 * @property {Record<string, any>} spec  its RobotSpecMsg (width, height, com, max_speed, ...)
 * @property {string} agent  the agent process that drives it ("": not known)
 * @property {PageLaser[]} lasers
 */

/**
 * @typedef {object} PageWall
 * @property {Xy[]} corners
 * @property {number} height  m
 */

/**
 * @typedef {object} Obstacle  a rectangle (iw_zenoh/messages/world.py)
 * @property {string} name
 * @property {number} x0
 * @property {number} y0
 * @property {number} x1
 * @property {number} y1
 * @property {number} [height]  m
 */

/**
 * @typedef {object} PageScene  everything static of one revision of the world
 * @property {"scene"} type
 * @property {number} revision
 * @property {string} name
 * @property {number} width  m
 * @property {number} height  m
 * @property {PageWall[]} walls
 * @property {Obstacle[]} obstacles
 * @property {[number, number, number][]} beacons  x, y, height
 * @property {[number, number, number][]} targets  x, y, radius
 * @property {PageRobot[]} robots
 * @property {number} period_ns
 */

/**
 * @typedef {object} PageFrame  one tick's poses, in the order of ids
 * @property {"frame"} type
 * @property {number} tick
 * @property {number} t_ns
 * @property {number[] | null} ids  null: the ids last sent
 * @property {number[]} x
 * @property {number[]} y
 * @property {number[]} heading  rad
 * @property {string} state  one letter a robot: d driving, h held, w watchdog, c collided (STATE_NAMES)
 * @property {string} held_reason
 * @property {number} sent_ms
 * @property {number} tick_wall_ms
 */

/**
 * @typedef {object} PageStatus  the clock
 * @property {"status"} type
 * @property {number} tick
 * @property {number} t_ns
 * @property {string} mode
 * @property {boolean} running
 * @property {number} rtf
 * @property {number} period_ns
 */

/**
 * @typedef {object} PageReadings  proximity readings that changed: robot id (text) to one per sensor
 * @property {"readings"} type
 * @property {number} tick
 * @property {Record<string, (number | null)[]>} prox
 */

/**
 * @typedef {object} PageScans  laser scans that changed: robot id (text) to one list per scanner
 * @property {"scans"} type
 * @property {number} tick
 * @property {Record<string, (number | null)[][]>} scans
 */

/**
 * @typedef {object} PageReading  everything known of one robot now
 * @property {"reading"} type
 * @property {number} robot_id
 * @property {Record<string, any> | null} reading  its last SensorReading, plus agent
 * @property {number | null} speed  m/s
 * @property {[number, number] | null} motors
 * @property {[number, number, number] | null} pose
 * @property {{tick: number, t_ns: number, kind: string, reason: string}[]} events
 */

/**
 * @typedef {object} PageHeard  radio messages heard: [to, from, distance m, text]
 * @property {"heard"} type
 * @property {number} tick
 * @property {[number, number, number, string][]} messages
 */

/**
 * @typedef {object} PageEvent
 * @property {"event"} type
 * @property {number} tick
 * @property {number} t_ns
 * @property {string} kind
 * @property {string} reason
 * @property {number} robot_id
 * @property {Xy | null} where
 */

/**
 * @typedef {object} TimelineMark  an incident on the replay's timeline
 * @property {number} t_ns
 * @property {string} kind
 * @property {string} what
 * @property {number[]} robots
 */

/**
 * @typedef {object} PageTimeline
 * @property {"timeline"} type
 * @property {number} start_ns
 * @property {number} end_ns
 * @property {number} position_ns
 * @property {boolean} playing
 * @property {number} rate
 * @property {TimelineMark[] | null} marks  null: the ones sent before
 */

/**
 * @typedef {object} PageError  a command the server refused, and why
 * @property {"error"} type
 * @property {string} error
 */

/**
 * @typedef {PageHello | PageScene | PageFrame | PageStatus | PageReadings | PageScans | PageReading
 *   | PageHeard | PageEvent | PageTimeline | PageError} PageMessage
 */

/**
 * @typedef {object} PageCommand  what the page asks (unknown fields are refused)
 * @property {string} cmd  start pause stop step remove add_obstacle move_obstacle remove_obstacle reading seek rate scans
 * @property {number} [robot_id]
 * @property {Obstacle | null} [obstacle]
 * @property {number} [steps]
 * @property {number} [at_ns]
 * @property {number} [rate]
 * @property {"all" | "selected" | "none"} [scans]
 */

export {};
