"""`python -m ur3dq.cli` runs the CLI (the same as the `ur3dq` command)."""
from ur3dq.cli.app import main

main()
