"""The maps, grids, parameters, chair specs and scenarios (``scenarios/``) that ship with the
package, installed as ``iw_zenoh.data`` (``iw_zenoh.scenario.shipped`` finds them): data only, no code."""
