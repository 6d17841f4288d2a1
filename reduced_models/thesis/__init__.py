"""The deployable six-bar thesis's force method (Appendix C port, ``force_method``, on the chain
read by ``chain``)."""
