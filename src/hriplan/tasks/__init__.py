"""Task descriptions (task files and their validation)."""
