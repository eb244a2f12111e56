"""Active sonar from hydrophones to contacts (thesis ch. 4): beam time series per ping
(``active_beams``), the wideband Doppler matched-filter bank (``matched_filter``, eqs.
(4.7)-(4.8)), CFAR detection and contacts with absolute Doppler (``cfar``, eq. (4.9)), and the
HFM -> BPSK bracket mode of thesis 4.2.3."""
