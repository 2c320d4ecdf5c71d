"""World-model calibration from probe points on features, and measurement planning
(the calibration report: sections 1-6 and Appendix 1)."""
