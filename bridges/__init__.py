"""Bridges to the outside (installed as ``iw_zenoh.bridges``): legacy XML/UDP and RS-232."""
