"""Where recordings go by default; its one sample ships, installed as ``iw_zenoh.samples``
(``iw_zenoh.scenario.shipped.sample_recording``): data only, no code."""
