"""`python -m ur3dq`: the same as the `ur3dq` command."""
from ur3dq.cli.app import main

if __name__ == "__main__":
    main()
