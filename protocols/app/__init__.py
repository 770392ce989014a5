"""The `dyno` application: the commands' table (cli.py) and one module per command, which declares its own arguments."""
