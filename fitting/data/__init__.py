"""Records to what the objectives compare: screened campaigns (`campaign`), stick and slip
detection (`sticks`), cycle features (`features`) and synthetic campaigns for tests
(`synthetic`)."""
