"""A probe's steps (`uros probe`), each over one frozen probe context (probesteps/context.py), as
steps/ holds a build's: commands/probe.py is their sequence."""
