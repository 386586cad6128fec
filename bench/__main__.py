"""Run every benchmark module and rewrite docs/benchmarks.md."""
