"""Space carving of link geometry (paper II-A.2): blanks, swept neighbours, achieved limits."""
