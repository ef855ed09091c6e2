"""Each tick's logic, free of I/O: the world, the collision check, the sensors and the radio.

The nodes of :mod:`iw_zenoh.nodes` wire these to the bus; ``iwz resim`` and the tests call them
directly. Nothing here imports zenoh, reads a clock or touches the network, files or threads.
"""
