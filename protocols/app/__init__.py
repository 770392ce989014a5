"""The `dyno` application: the parser table (cli.py) and one module per command."""
