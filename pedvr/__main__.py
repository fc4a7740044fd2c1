from pedvr.cli import main

# Guarded: `pedvr sweep` starts Dask worker processes with the spawn method,
# which imports the main module again in each; unguarded, each would run the CLI.
if __name__ == "__main__":
    raise SystemExit(main())
