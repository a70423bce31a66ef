"""fuzzynav: controller."""
