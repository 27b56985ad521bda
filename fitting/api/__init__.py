"""One call per job, returning a result object with `summary()`, `plot(path)` and
`to_json(path)`: `campaign.fit`, `posterior.sample`, `discovery.discover`."""
