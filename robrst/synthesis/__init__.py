"""Controller synthesis: analytic pole placement, CasADi NLP, convex variant."""
