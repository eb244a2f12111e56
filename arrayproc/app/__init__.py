"""The application layer: command line, commands, demo, batch runs, and the public API that
loads the stage registry before building chains."""
