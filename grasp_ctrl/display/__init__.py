"""What a command shows besides its files: the one-line progress and charts (matplotlib, lazily)."""
