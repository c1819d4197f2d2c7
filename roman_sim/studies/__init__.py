"""The paper reproduction: reference runs, their raw data, claims and tables, the paper preset and
the independent scorer that checks them.
"""
