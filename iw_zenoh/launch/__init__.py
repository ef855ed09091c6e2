"""`iwz run`: the launcher that starts a scenario's processes, supervises, restarts and judges them."""
