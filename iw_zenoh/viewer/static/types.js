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
 * @property {string} driver  this page's name as a driver (VIEWER#N)
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
 * @property {Record<string, any>} spec  its RobotSpecMsg (width_m, height_m, com, max_speed_mps, ...)
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
 * @typedef {object} DriveState  what a chair's agent does with its driver's input (iw.DriveState, docs/driving.md)
 * @property {number} robot_id
 * @property {string} driver  who drives ("" nobody)
 * @property {number} seq  the driver's last input applied
 * @property {number} level  speed level 1..5
 * @property {"off" | "safe" | "assist"} assist
 * @property {number} v_mps  the command after shared control
 * @property {number} w_radps
 * @property {number} input_v_mps  the driver's command before shared control
 * @property {number} input_w_radps
 * @property {boolean} intervened  shared control changed the command this tick
 * @property {number | null} nearest_m  the nearest obstacle seen (null: nothing in range)
 * @property {number[] | null} goal  the go-there goal, [x, y] m
 * @property {boolean} stale  the dead-man tripped (no input for 300 ms)
 * @property {string} refused  the last driver refused (another drives and it did not take over)
 */

/**
 * @typedef {object} PageDrive  a chair's drive state (only chairs whose agent accepts a driver)
 * @property {"drive"} type
 * @property {number} robot_id
 * @property {DriveState | null} state  null: the chair left
 */

/**
 * @typedef {object} PageError  a command the server refused, and why
 * @property {"error"} type
 * @property {string} error
 * @property {number | null} drive_robot  the chair a refused drive was for
 */

/**
 * @typedef {PageHello | PageScene | PageFrame | PageStatus | PageReadings | PageScans | PageReading
 *   | PageHeard | PageEvent | PageTimeline | PageDrive | PageError} PageMessage
 */

/**
 * @typedef {object} PageCommand  what the page asks (unknown fields are refused)
 * @property {string} cmd  start pause stop step remove add_obstacle move_obstacle remove_obstacle reading seek rate scans drive
 * @property {number} [robot_id]
 * @property {Obstacle | null} [obstacle]
 * @property {number} [steps]
 * @property {number} [at_ns]
 * @property {number} [rate]
 * @property {"all" | "selected" | "none"} [scans]
 * @property {PageDriveInput | null} [drive]  a drive command's input
 */

/**
 * @typedef {object} PageDriveInput  a drive command's input, relayed to the chair as an iw.DriveInput
 * @property {number} [seq]
 * @property {number} [x]  stick right, -1..1
 * @property {number} [y]  stick forward, -1..1
 * @property {number} [buttons]  bit 0: the dead-man held
 * @property {number} [level]  speed level 1..5
 * @property {boolean} [take]  take the chair over
 * @property {boolean} [release]  leave it
 * @property {number[] | null} [goto]  go there, [x, y] m
 * @property {"off" | "safe" | "assist" | null} [assist]  a new shared-control level
 */

export {};
