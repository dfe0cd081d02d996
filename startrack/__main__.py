"""``python -m startrack``: the same command line as the ``startrack`` script."""

from startrack.cli import main

if __name__ == "__main__":
    main()
