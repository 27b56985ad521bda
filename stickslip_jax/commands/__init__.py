"""Subcommands of the `stickslip` CLI (see `stickslip_jax.cli`)."""
