"""fuzzynav: world."""
