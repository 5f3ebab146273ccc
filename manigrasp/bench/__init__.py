"""The benchmark harness: config, trial enumeration, results store, statistics, report."""
