"""The FTCAPN paper (Wang & Song 2019): nominal report (``report``) and figures (``figures``)."""
