"""``python -m etsid`` entry point."""

from etsid.cli import main

if __name__ == "__main__":
    main()
