"""Other tools' files read as hriplan data (Kautham problem files)."""
