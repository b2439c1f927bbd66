"""The `hriplan` command line."""
