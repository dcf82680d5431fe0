"""``python -m bayesmap``: the command line, as the ``bayesmap`` script runs it."""

from bayesmap.cli import main

if __name__ == "__main__":
    main()
