"""One module per `uros` command (west's src/west/app/ idea): each runs one command over the
workspace model, the planners, the host probes and the pure builders, and imports nothing above
them. cli.py parses options and calls one function here."""
