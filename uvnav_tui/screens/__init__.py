"""Full screens of the console: the main console screen, help, message log and tables."""
