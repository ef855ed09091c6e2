"""Agent programs (installed as ``iw_zenoh.agents``): pure policies with thin ``main()`` shells."""
