"""``iwz study``: many lock-step runs of a scenario (seeds, conditions), every ``iwz report``
measure aggregated with its mean, spread and 95 % interval, conditions side by side, as JSON and
an HTML page (docs/study.md).

``--set FIELD=VALUE`` is :mod:`iw_zenoh.scenario.fields`' (``iwz run`` takes it too).
"""
