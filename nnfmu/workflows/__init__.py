"""The use cases, on a floor of their own above every stage: train, co-simulate, close the loop, road test,
campaigns, the demo, and the single-stage commands the CLI offers. `nnfmu/cli.py` and `bench/` import from here;
nothing under a stage imports from here."""
