"""`make demo`: placeholder until the simulated move lands."""

print("robodcn demo: not yet wired")
