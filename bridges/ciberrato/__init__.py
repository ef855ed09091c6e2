"""The legacy Ciber-Rato / Intellwheels XML-over-UDP protocol: a pure codec and (to come) the bridge node."""
