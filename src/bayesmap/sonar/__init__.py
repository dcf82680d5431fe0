"""sonar."""
