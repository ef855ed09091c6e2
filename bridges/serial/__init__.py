"""RS-232 serial bridge: board protocol, chair-board emulator and the bridge node."""
