"""One module per process role: logic class, ``run(bus, ...)`` wiring, ``main(argv)``."""
