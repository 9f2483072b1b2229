/* SPDX-License-Identifier: Apache-2.0 */
/* The SoC's UART (8N1, a receive FIFO, one transmit holding register): polled. */
#ifndef HG_UART_H
#define HG_UART_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

bool uart_rx_ready(void);
uint8_t uart_rx(void);                        /* only after uart_rx_ready() */
void uart_send(const uint8_t *d, size_t n);   /* waits for the transmitter byte by byte */
uint32_t uart_baud(void);

#endif /* HG_UART_H */
