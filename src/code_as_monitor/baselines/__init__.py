"""Baselines behind the agent interface: ``open-loop`` (the paper's CLIPort column), ``inner-monologue``
(VQA success check at each subgoal end, then re-plan) and ``doremi`` (VQA on every constraint every
``k`` seconds during execution).

Offline their VQA is ``vqa-standin`` (:mod:`.vqa_standin`), a rule-based single-image stand-in,
NOT a VLM; with the ``openai`` backend a real VLM answers (:mod:`.vqa`). Modules import lazily:
``from code_as_monitor.baselines.agents import CheckingAgent``.
"""
