"""The application layer that composes the simulator with planners: single runs and studies."""
