"""The pure simulation core: maps, bodies, motors, collision and sensors.

Nothing here touches the network, files, clocks or global random state.
"""
