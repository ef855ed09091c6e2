"""What every role process shares: how it starts and stops (start_role), its common arguments, its typed options."""
