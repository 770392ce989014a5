"""The `dyno` command line: the commands' table (cli.py) and one module per command, which
declares its arguments, parses, calls the library below and prints; bench/ the benchmarks'
commands. Nothing below imports it."""
