"""The replay page: a recorded bag's frames, drawn with the Create's and the arm's views."""
