"""fuzzynav: app."""
