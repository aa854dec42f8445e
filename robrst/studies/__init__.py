"""The paper's experiments and twin runs built on designs (above the design pipeline)."""
