"""The least-squares verb over any parameter pytree (`lsq`) and what is built on it: the
campaign fit with multi-start and reweighting (`fit`), batches of campaigns (`batch`),
the pitching fit (`pitch`) and the microsqueeze fit (`microsqueeze`)."""
