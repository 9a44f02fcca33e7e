"""mjchar's dynamic layer: the simulated Character, controllers, scenarios, metrics and the CLI."""
