"""Scenario files: what `iwz run` starts and how it judges the run (`file`), the spec files a scenario
or an agent lays over a chair (`specfile`), and the scenarios that ship with the package (`shipped`)."""
