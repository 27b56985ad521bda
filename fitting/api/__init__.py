"""One call per job, returning a result object with `summary()`, `plot(path)` and
`to_json(path)`: `campaign.fit`, `posterior.sample`, `discovery.discover`,
`design.design_map`; `plan.plan_records` prints its plan and has `to_json(path)`."""
