"""Recording every key to MCAP, checking and recovering files, replaying them."""
